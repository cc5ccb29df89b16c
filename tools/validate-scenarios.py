#!/usr/bin/env python3
"""Validates scenario files against data/scenarios/scenario.schema.json with
python3's jsonschema module (Debian: python3-jsonschema, in tools/setup.sh).

Usage: tools/validate-scenarios.py SCHEMA FILE...
Exit status 0 when every file validates, 1 when one does not, 2 when the
check cannot run (the module is missing: it says so, it never passes silently).
"""
import json
import sys


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    try:
        import jsonschema
    except ImportError as e:
        print("validate-scenarios: cannot run: python3's jsonschema module is missing (%s); "
              "install python3-jsonschema (tools/setup.sh does)" % e, file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        schema = json.load(f)
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    validator = cls(schema)
    failed = 0
    for path in argv[2:]:
        with open(path) as f:
            doc = json.load(f)
        errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))
        for e in errors:
            pointer = "".join("/" + str(p) for p in e.absolute_path) or "/"
            print("%s: %s: %s" % (path, pointer, e.message))
        if errors:
            failed += 1
        else:
            print("%s: valid against %s" % (path, argv[1]))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
