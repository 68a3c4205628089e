import sys

from aquaspec.cli import main

sys.exit(main())
