"""python -m motivml.cli"""

from . import console

console()
