"""motivml: variability models for robot software, checked with SAT and bound into variants."""

__version__ = "0.1.0"
