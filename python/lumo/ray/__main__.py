"""``python -m lumo.ray render SCENE [lumo render options] --workers N -o OUT``."""

import sys

from . import main

sys.exit(main())
