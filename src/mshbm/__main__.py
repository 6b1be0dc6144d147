"""``python -m mshbm`` runs the command line (:mod:`mshbm.cli`)."""
import sys

from .cli import main

sys.exit(main())
