"""The ROS message types Debian does not package, generated with genpy from the ``.msg`` files in ``msg/``.

``baxter_core_msgs`` (JointCommand, AssemblyState: RethinkRobotics/baxter_common) and ``iiwa_msgs``
(JointPosition, JointQuantity: IFL-CAMP/iiwa_stack) are interface definitions; their ``.msg`` text ships with the
plugin and genpy (the generator catkin runs for rospy) turns it into Python modules on first use, in a cache
directory (``$PLIANT_CACHE_DIR``, else ``$XDG_CACHE_HOME/pliant``, else ``~/.cache/pliant``; a temporary directory
when none is writable) keyed by a hash of the ``.msg`` texts and genpy's version -- never into the source tree.
The generated serialisation is genpy's own, and the md5 sums are those of the robots' own builds (the tests check
them against independent public copies), so the real robots accept the messages.

A message package already importable (a catkin workspace on ``PYTHONPATH``) is used instead when its md5 sums
match; when they differ the error says so rather than talking a different protocol.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path

from pliant.api import ConfigError

#: the shipped message definitions, one directory per ROS package
MSG_DIR = Path(__file__).resolve().parent / "msg"
#: the packages generated here
PACKAGES = ("baxter_core_msgs", "iiwa_msgs", "pr2_msgs")

_lock = threading.Lock()
_ready: Path | None = None


def message_files() -> dict[str, Path]:
    """``{"package/Name": path}`` of every shipped ``.msg`` file."""
    return {f"{p}/{f.stem}": f for p in PACKAGES for f in sorted((MSG_DIR / p).glob("*.msg"))}


def _header_text() -> str:
    """std_msgs/Header's definition, from Debian's std_msgs (its ``.msg`` files are not installed)."""
    from std_msgs.msg import Header

    return Header._full_text


def _context():
    """A genmsg context with std_msgs/Header and every shipped message loaded."""
    import genmsg
    import genmsg.msg_loader as loader

    context = genmsg.MsgContext.create_default()
    loader.load_msg_from_string(context, _header_text(), "std_msgs/Header")
    specs = {name: loader.load_msg_from_file(context, str(path), name) for name, path in message_files().items()}
    search = {p: [str(MSG_DIR / p)] for p in PACKAGES}
    for spec in specs.values():
        loader.load_depends(context, spec, search)
    return context, specs, search


def expected_md5sums() -> dict[str, str]:
    """``{"package/Name": md5}`` computed by genmsg from the shipped ``.msg`` files (what ROS puts on the wire)."""
    import genmsg

    context, specs, _ = _context()
    return {name: genmsg.compute_md5(context, spec) for name, spec in specs.items()}


def _key() -> str:
    digest = hashlib.sha256()
    try:
        digest.update(importlib.metadata.version("genpy").encode())
    except importlib.metadata.PackageNotFoundError:
        import genpy

        digest.update(str(Path(genpy.__file__).stat().st_mtime).encode())
    digest.update(_header_text().encode())
    for name, path in message_files().items():
        digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def cache_root() -> Path:
    """Where generated message packages go (see the module docstring); created when missing."""
    candidates = []
    if os.environ.get("PLIANT_CACHE_DIR"):
        candidates.append(Path(os.environ["PLIANT_CACHE_DIR"]))
    if os.environ.get("XDG_CACHE_HOME"):
        candidates.append(Path(os.environ["XDG_CACHE_HOME"]) / "pliant")
    candidates.append(Path.home() / ".cache" / "pliant")
    candidates.append(Path(tempfile.gettempdir()) / f"pliant-{os.getuid() if hasattr(os, 'getuid') else 'user'}")
    for root in candidates:
        target = root / "ros1_msgs"
        try:
            target.mkdir(parents=True, exist_ok=True)
            probe = target / f".probe-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
            return target
        except OSError:
            continue
    raise ConfigError("no writable cache directory for the generated ROS messages (set PLIANT_CACHE_DIR)",
                      field="PLIANT_CACHE_DIR", value=[str(c) for c in candidates])


def generate(destination: Path) -> Path:
    """Generate every shipped package as Python (``<destination>/<package>/msg/_Name.py``) with genpy."""
    import genpy.generator

    context, specs, search = _context()
    for package in PACKAGES:
        msg_dir = destination / package / "msg"
        msg_dir.mkdir(parents=True, exist_ok=True)
        (destination / package / "__init__.py").write_text("")
        names = sorted(n.split("/")[1] for n in specs if n.startswith(package + "/"))
        for name in names:
            code = "\n".join(genpy.generator.msg_generator(context, specs[f"{package}/{name}"], search))
            (msg_dir / f"_{name}.py").write_text(code + "\n")
        (msg_dir / "__init__.py").write_text("".join(f"from ._{n} import *\n" for n in names))
    return destination


def _installed_elsewhere(package: str, ours: Path) -> bool:
    spec = importlib.util.find_spec(package) if package not in sys.modules else sys.modules[package].__spec__
    if spec is None or not spec.submodule_search_locations:
        return False
    return all(not Path(p).resolve().is_relative_to(ours.resolve()) for p in spec.submodule_search_locations)


def ensure_generated() -> Path:
    """Generate the packages into the cache (once per content hash), put the cache on ``sys.path`` and return it."""
    global _ready
    with _lock:
        if _ready is not None:
            return _ready
        destination = cache_root() / _key()
        if not (destination / "iiwa_msgs" / "msg" / "__init__.py").exists():
            staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=destination.parent))
            try:
                generate(staging)
                try:
                    staging.rename(destination)
                except OSError:          # another process generated it first: use theirs
                    if not (destination / "iiwa_msgs" / "msg" / "__init__.py").exists():
                        raise
            finally:
                shutil.rmtree(staging, ignore_errors=True)
        if str(destination) not in sys.path:
            sys.path.append(str(destination))
        _ready = destination
        return destination


@functools.cache
def message_class(type_name: str) -> type:
    """The rospy message class of ``"baxter_core_msgs/JointCommand"`` and the like (generated on first use).

    A package importable from elsewhere (a catkin workspace) is used when its md5 sum matches the shipped
    definition; otherwise :class:`~pliant.errors.ConfigError` names both sums.
    """
    package, name = type_name.split("/")
    if package not in PACKAGES or f"{package}/{name}" not in message_files():
        raise ConfigError("not a message this plugin ships", field="type", value=type_name)
    ours = ensure_generated()
    cls = getattr(importlib.import_module(f"{package}.msg"), name)
    if _installed_elsewhere(package, ours):
        expected = expected_md5sums()[type_name]
        if cls._md5sum != expected:
            raise ConfigError(f"the installed {package} defines {name} with md5 {cls._md5sum}, but the robot's is "
                              f"{expected}; remove it from PYTHONPATH or rebuild it from the robot's definitions",
                              field="type", value=type_name)
    return cls
