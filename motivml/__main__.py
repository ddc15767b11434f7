"""python -m motivml: the motivml command (also where no console script is on PATH)."""

from .cli import console

console()
