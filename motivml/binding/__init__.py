"""The one SAT encoding and what is computed on it: checks, explanations, resolution, code generation, change impact."""

PREFERENCES = ("late", "dynamic")  # what a resolution may prefer for bindings a configuration leaves open
