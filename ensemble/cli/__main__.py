"""``python -m ensemble.cli``: the same commands as the ``hertzian`` script."""

from . import main

main()
