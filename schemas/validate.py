"""Validates JSON documents against the schemas of this folder.

Usage: python3 schemas/validate.py SCHEMA_NAME DOCUMENT.json [...]
(SCHEMA_NAME: grade, inspection, check, diagnosis, report, compare, figures).
Exit 0 when every document is valid; 1 with each error's JSON path.
Uses python3-jsonschema (Debian), draft 2020-12; the schemas refer to each
other by their $id (urn:ttp:schema:NAME).
"""
import json
import pathlib
import sys

import jsonschema
from referencing import Registry, Resource

here = pathlib.Path(__file__).resolve().parent
registry = Registry()
schemas = {}
for path in sorted(here.glob("*.schema.json")):
    schema = json.loads(path.read_text())
    schemas[path.name.split(".")[0]] = schema
    registry = registry.with_resource(schema["$id"], Resource.from_contents(schema))

name, documents = sys.argv[1], sys.argv[2:]
validator = jsonschema.Draft202012Validator(schemas[name], registry=registry)
failed = False
for doc_path in documents:
    doc = json.loads(pathlib.Path(doc_path).read_text())
    for error in sorted(validator.iter_errors(doc), key=lambda e: list(e.path)):
        failed = True
        where = "/".join(str(p) for p in error.absolute_path) or "(root)"
        print(f"{doc_path}: {where}: {error.message[:300]}")
sys.exit(1 if failed else 0)
