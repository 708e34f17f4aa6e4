"""``python -m hertzian.ensemble.cli``: the same commands as the ``hertzian`` script."""

from . import main

main()
