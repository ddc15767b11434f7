"""The feature model's plain data and turning checked documents into it."""
