import sys

try:
    from .cli import main
except KeyboardInterrupt:  # Ctrl-C while Python imports the command line: stop as main() would
    if sys.stderr is not None:
        print("encal: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
