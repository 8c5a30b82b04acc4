"""The package version, in the lowest layer so that generated code can name it without importing the
applications."""
VERSION = "0.1.0"
