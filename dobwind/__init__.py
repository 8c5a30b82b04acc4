"""dobwind: airframe description -> verified, dependency-free C wind estimator."""
from dobwind.model.version import VERSION as __version__

__all__ = ["__version__"]
