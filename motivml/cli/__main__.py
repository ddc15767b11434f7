"""python -m motivml.cli"""

from . import main

main()
