"""The one SAT encoding and what is computed on it: checks, explanations, resolution, code generation, change impact."""
