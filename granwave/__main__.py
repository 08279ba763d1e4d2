"""``python -m granwave`` runs the ``granwave`` command (same as the console script)."""

from .cli import main

if __name__ == "__main__":
    main()
