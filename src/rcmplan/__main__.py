"""python -m rcmplan: the command line."""

import sys

from rcmplan.cli import main

sys.exit(main())
