"""``peridyn new-plugin``: a plugin package skeleton (entry point, model module with Params, a
numba kernel and the wiring class, tests using :mod:`peridyn.testing`)."""
from __future__ import annotations

import keyword
import re
from importlib import resources
from pathlib import Path

from ..core.errors import InputError

KINDS = ("material", "damage", "contact", "compute", "stress-law")


def _names(name: str) -> dict[str, str]:
    package = re.sub(r"[^0-9a-zA-Z_]", "_", name.strip()).lower().strip("_")
    if not package or package[0].isdigit() or keyword.iskeyword(package):
        raise InputError(f"NAME {name!r} cannot be a Python package name", fix="give letters, digits and underscores, starting with a letter")
    words = [w for w in package.split("_") if w]
    return {
        "package": package,
        "distribution": package.replace("_", "-"),
        "class_name": "".join(w.capitalize() for w in words),
        "display": " ".join(w.capitalize() for w in words),
        "output_name": "_".join(w.capitalize() for w in words),
    }


def new_plugin(name: str, *, kind: str = "material", directory: Path = Path(".")) -> Path:
    """Create ``directory/<package>`` for a plugin of ``kind``; return its path."""
    if kind not in KINDS:
        raise InputError(f"unknown plugin kind {kind!r}", fix=f"use one of: {', '.join(KINDS)}")
    names = _names(name)
    root = Path(directory) / names["package"]
    if root.exists():
        raise InputError(f"{root} already exists", fix="choose another name or folder")
    template_root = resources.files("peridyn.plugins") / "templates"
    files = {
        "pyproject.toml": template_root / "pyproject.toml.tmpl",
        "README.md": template_root / "README.md.tmpl",
        f"src/{names['package']}/__init__.py": template_root / "init.py.tmpl",
        f"src/{names['package']}/plugin.py": template_root / kind / "plugin.py.tmpl",
        f"src/{names['package']}/model.py": template_root / kind / "model.py.tmpl",
        "tests/test_model.py": template_root / kind / "test_model.py.tmpl",
    }
    for rel, src in files.items():
        text = src.read_text()
        for key, value in names.items():
            text = text.replace("{{" + key + "}}", value)
        text = text.replace("{{kind}}", kind)
        dest = root / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(text)
    return root
