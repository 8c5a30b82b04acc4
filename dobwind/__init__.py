"""dobwind: airframe description -> verified, dependency-free C wind estimator."""

__version__ = "0.1.0"
