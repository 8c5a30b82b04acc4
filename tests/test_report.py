"""`dobwind report`: one self-contained HTML page that a real browser opens without errors and with every
figure decoded (headless Chromium; `make test` installs the Debian `chromium` package through .ci/system-deps)."""
from __future__ import annotations

import base64
import re
import shutil
import subprocess

import pytest

from dobwind.cli.app import main
from tests.helpers import M300
from tests.shared_figures import use_shared_figures

# Injected into a copy of the page for the browser run only: records script errors and console.error
# calls, then, after load, whether each image decoded, into an element that --dump-dom prints.
PROBE_HEAD = """<script>
window.__problems = [];
window.addEventListener("error", function (e) { window.__problems.push("error: " + e.message); }, true);
var __consoleError = console.error;
console.error = function () { window.__problems.push("console: " + Array.from(arguments).join(" ")); __consoleError.apply(console, arguments); };
</script>"""
PROBE_TAIL = """<script>
window.addEventListener("load", function () {
  var images = Array.from(document.images);
  var shown = images.filter(function (i) { return i.complete && i.naturalWidth > 100 && i.getBoundingClientRect().width > 100; });
  var out = document.createElement("pre");
  out.id = "probe";
  out.textContent = "images=" + images.length + " shown=" + shown.length + " problems=" + JSON.stringify(window.__problems);
  document.body.appendChild(out);
});
</script>"""


@pytest.fixture(scope="module")
def report_html(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    log = folder / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "25", "-o", str(log)]) == 0
    with pytest.MonkeyPatch.context() as patch:
        use_shared_figures(patch)
        assert main(["report", str(M300), str(log), "-o", str(folder / "report.html")]) == 0
    return folder / "report.html"


def test_report_is_self_contained_and_complete(report_html):
    page = report_html.read_text()
    # No network: nothing fetched from anywhere (every image is inline data).
    assert not re.search(r"""(src|href)\s*=\s*["'](?!data:)""", page)
    assert "http://" not in page and "https://" not in page
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) >= 3  # the replay figure and the analysis figures
    for data in images:
        assert base64.b64decode(data).startswith(b"\x89PNG\r\n\x1a\n")
    for section in ("Airframe", "Errors", "Status", "Figures"):
        assert f"<h2>{section}</h2>" in page
    errors = re.search(r'<table id="errors">(.*?)</table>', page, re.S).group(1)
    assert "horizontal speed, every sample" in errors and re.search(r'class="num">\d+\.\d{3}<', errors)
    status = re.search(r'<table id="status">(.*?)</table>', page, re.S).group(1)
    counts = [int(c) for c in re.findall(r'<td>(?:none \(status 0\)|SETTLING)</td><td>\w+</td><td class="num">(\d+)<', status)]
    assert len(counts) == 2 and counts[1] > 0  # the start of a log is always settling


def test_report_opens_in_headless_chromium_without_errors(report_html, tmp_path):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    assert browser, "chromium is needed (`make test` installs it through .ci/system-deps)"
    page = report_html.read_text()
    probed = tmp_path / "probed.html"
    probed.write_text(page.replace("<head>", "<head>\n" + PROBE_HEAD, 1).replace("</body>", PROBE_TAIL + "\n</body>", 1))
    done = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1200,900",
                           "--virtual-time-budget=5000", "--dump-dom", probed.as_uri()],
                          capture_output=True, text=True, timeout=120)
    probe = re.search(r'<pre id="probe">images=(\d+) shown=(\d+) problems=(.*?)</pre>', done.stdout)
    assert probe, f"the page did not finish loading:\n{done.stderr[-2000:]}"
    images, shown, problems = int(probe.group(1)), int(probe.group(2)), probe.group(3)
    assert images >= 3 and shown == images, f"{shown} of {images} figures decoded and laid out"
    assert problems == "[]", problems


def test_report_on_a_bad_log_is_one_line_and_writes_nothing(tmp_path, capsys):
    log = tmp_path / "bad.csv"
    log.write_text("t,vel_n\n0,1\n")
    out = tmp_path / "report.html"
    assert main(["report", str(M300), str(log), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "bad.csv" in err and "column" in err
    assert not out.exists() and list(tmp_path.iterdir()) == [log]


@pytest.mark.parametrize("name, said", [("r.pdf", "'.pdf'"), ("r.png", "'.png'"), ("r", "no extension")])
def test_report_refuses_an_output_that_is_not_html(tmp_path, capsys, name, said):
    """The page is HTML whatever -o says: r.pdf used to receive HTML. The refusal comes before the log is
    read (a good log, so only the name can be the reason) and names -o and the extension."""
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "2", "--rate", "10", "-o", str(log)]) == 0
    capsys.readouterr()
    assert main(["report", str(M300), str(log), "-o", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "-o" in err and said in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == [log]


def test_report_takes_html_and_htm_whatever_the_case(tmp_path):
    from dobwind.cli.report import PAGE_SUFFIXES
    from dobwind.io.outputs import Target, check_target

    (tmp_path / "dir.d").mkdir()
    for name in ("r.html", "R.HTML", "page.htm", "dir.d/r.Html"):
        check_target(Target("-o", str(tmp_path / name), suffixes=PAGE_SUFFIXES))
