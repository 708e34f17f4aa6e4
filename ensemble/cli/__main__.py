"""``python -m hertzian.cli``: the same commands as the ``hertzian`` script."""

from hertzian.cli import main

main()
