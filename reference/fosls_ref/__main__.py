import os
import sys

if not __package__:  # run as `python path/to/fosls_ref ...`
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from fosls_ref.cli import main
else:
    from .cli import main

sys.exit(main())
