"""Build the Blender extension zip: ``python -m splicer.blender.build -o splicer_blender.zip``.

The zip is an extension (Blender 4.2+: Edit > Preferences > Get Extensions > Install from
Disk) laid out as::

    blender_manifest.toml  __init__.py  core.py  ui.py   the add-on (splicer/blender/)
    splicer/...                                           the pure-Python splicer package, bundled
    wheels/*.whl                                          only with --wheels DIR (see below)

splicer's own code is bundled; its compiled dependencies (numba, llvmlite, scipy, bvhio,
pandas, matplotlib, PyYAML; Blender brings numpy) are not, because their wheels are
per-platform.  Either pass ``--wheels DIR`` with wheels for Blender's Python and your
platform (``pip download numba scipy bvhio pandas matplotlib PyYAML --only-binary=:all:
--python-version 3.11 --platform manylinux_2_28_x86_64 -d DIR``; they are copied into the
zip and listed in the manifest's ``wheels``, Blender installs them with the extension),
or install them into Blender's Python once (``<blender>/python/bin/python3.11 -m pip
install numba scipy bvhio pandas matplotlib PyYAML``).
"""

from __future__ import annotations

import argparse
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
PACKAGE = HERE.parent
ADDON_FILES = ("__init__.py", "core.py", "ui.py")


def build(out: str | Path, wheels: str | Path | None = None) -> Path:
    """Write the extension zip to ``out``; returns its path."""
    out = Path(out)
    manifest = (HERE / "blender_manifest.toml").read_text(encoding="utf-8")
    wheel_files = sorted(Path(wheels).glob("*.whl")) if wheels else []
    if wheels and not wheel_files:
        raise SystemExit(f"splicer.blender.build: no .whl files in {wheels}")
    if wheel_files:
        listed = ", ".join(f'"./wheels/{w.name}"' for w in wheel_files)
        manifest = manifest.replace("# wheels = []", f"wheels = [{listed}]")
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for f in ADDON_FILES:
            z.write(HERE / f, f)
        for f in sorted(PACKAGE.rglob("*.py")):
            rel = f.relative_to(PACKAGE)
            if rel.parts[0] in ("blender", "__pycache__") or "__pycache__" in rel.parts:
                continue
            z.write(f, str(Path("splicer") / rel))
        for w in wheel_files:
            z.write(w, f"wheels/{w.name}")
    tmp.replace(out)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m splicer.blender.build", description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="splicer_blender.zip", help="the zip to write")
    p.add_argument("--wheels", metavar="DIR", help="bundle these dependency wheels (listed in the manifest)")
    a = p.parse_args(argv)
    path = build(a.output, a.wheels)
    print(f"wrote {path} ({path.stat().st_size // 1024} KiB)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
