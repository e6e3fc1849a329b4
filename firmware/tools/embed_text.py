"""Write a text file as a C string (the flight config compiled into the ARM image).

    python embed_text.py FILE SYMBOL > out.c

defines ``const char SYMBOL[]`` (NUL-terminated), ``const unsigned SYMBOL_len`` and
``const char SYMBOL_name[]`` (the file's name, for the config's error messages).
"""

from __future__ import annotations

import sys
from pathlib import Path


def main(argv: list[str]) -> int:
    path, symbol = Path(argv[1]), argv[2]
    data = path.read_bytes()
    rows = [", ".join(str(b) for b in data[i:i + 24]) for i in range(0, len(data), 24)]
    body = ",\n    ".join(rows)
    print(f"/* generated from {path.name} by firmware/tools/embed_text.py: do not edit */")
    print(f"const char {symbol}[{len(data) + 1}] = {{\n    {body}{',' if data else ''} 0}};")
    print(f"const unsigned {symbol}_len = {len(data)}u;")
    print(f'const char {symbol}_name[] = "{path.name}";')
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
