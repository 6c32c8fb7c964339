import os
import sys

try:
    from .cli import main
except KeyboardInterrupt:  # Ctrl-C while Python imports the command line: stop as main() would
    if sys.stderr is not None:
        print("encal: interrupted", file=sys.stderr)
        sys.stderr.flush()
    # Not through the interpreter's teardown: an extension whose import the signal cut short may abort it.
    os._exit(130)

sys.exit(main())
