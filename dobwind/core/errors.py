"""The applications' name for the error types, which live with the model (the lowest layer) so that every
layer can raise them; see ``dobwind.model.errors``."""
from dobwind.model.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_OK, CheckFailed, InputError

__all__ = ["EXIT_BAD_INPUT", "EXIT_CHECK_FAILED", "EXIT_OK", "CheckFailed", "InputError"]
