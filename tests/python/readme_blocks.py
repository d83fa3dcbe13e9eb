"""The shell blocks of the README and docs/, for the tests that run them as written."""
import os
import re

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def sh_commands(section: str, document: str = "README.md") -> list:
    """The commands of the first ```sh block under heading `section` (e.g. "## Python") of
    `document` (a path from the repository's root): one per non-empty line, a trailing comment (two
    or more spaces, then #) cut off."""
    text = open(os.path.join(ROOT, document), encoding="utf-8").read()
    body = text[text.index(section):]
    body = body[: body.index("\n## ", 3)]
    block = re.search(r"```sh\n(.*?)```", body, re.S).group(1)
    return [line for line in (re.split(r"\s{2,}#", raw)[0].strip() for raw in block.splitlines()) if line]
