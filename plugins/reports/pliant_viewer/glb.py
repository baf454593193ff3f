"""Line segments as a binary glTF (GLB) that the page draws as WebGL lines: one non-instanced draw call.

viser's own line segments (``add_line_segments``) are instanced quads (three.js's ``LineSegments2``, six vertices
a segment, screen-space widths).  In a software WebGL renderer (SwiftShader: a headless Chromium, a machine
without a GPU) every instance of an instanced draw costs about 20-35 us however small it is: 2,000 tree edges took
half of a drawn frame of baxter-reach's page and 10,000 edges most of one, where the same segments as WebGL lines
(``gl.LINES``, one ``drawArrays``) cost no more than the noise (``docs/plugins/viewer.md``, Figures).  viser loads a
GLB with three.js's glTF loader, which turns a primitive of mode LINES into a ``LineSegments`` with an unlit
``LineBasicMaterial``: 1 pixel wide, in exactly the colour given (the glTF colour is linear; the page shows sRGB).

Only numpy and the standard library: the tests read the file back with :func:`read_lines`.
"""

from __future__ import annotations

import json
import struct

import numpy as np

_MAGIC, _JSON, _BIN = 0x46546C67, 0x4E4F534A, 0x004E4942
_LINES, _FLOAT, _ARRAY_BUFFER = 1, 5126, 34962


def srgb_to_linear(rgb) -> np.ndarray:
    """sRGB colour components 0-255 as linear values 0-1 (glTF's colours are linear)."""
    c = np.asarray(rgb, dtype=np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(values) -> np.ndarray:
    """The inverse of :func:`srgb_to_linear` (0-255, float)."""
    c = np.asarray(values, dtype=np.float64)
    return 255.0 * np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055)


def lines(segments: np.ndarray, colour) -> bytes:
    """A GLB of one LINES primitive: ``segments`` ``(n, 2, 3)`` (m), all in ``colour`` (RGB 0-255)."""
    points = np.ascontiguousarray(np.asarray(segments, dtype=np.float32).reshape(-1, 3))
    if not len(points):
        raise ValueError("no segments to draw")
    blob = points.tobytes()
    doc = {
        "asset": {"version": "2.0", "generator": "pliant_viewer"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": _LINES, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [*srgb_to_linear(colour).tolist(), 1.0],
                                                 "metallicFactor": 0.0, "roughnessFactor": 1.0},
                       "extensions": {"KHR_materials_unlit": {}}}],
        "extensionsUsed": ["KHR_materials_unlit"],
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(blob), "target": _ARRAY_BUFFER}],
        "accessors": [{"bufferView": 0, "componentType": _FLOAT, "count": len(points), "type": "VEC3",
                       "min": points.min(axis=0).tolist(), "max": points.max(axis=0).tolist()}],
    }
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(text), _JSON) + text + struct.pack("<II", len(blob), _BIN) + blob
    return struct.pack("<III", _MAGIC, 2, 12 + len(body)) + body


def read_lines(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """``(segments (n, 2, 3), colour (3,) 0-255)`` of a GLB written by :func:`lines`."""
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != _MAGIC or version != 2 or length != len(data):
        raise ValueError("not a GLB 2.0 file")
    n, kind = struct.unpack_from("<II", data, 12)
    if kind != _JSON:
        raise ValueError("the GLB's first chunk is not JSON")
    doc = json.loads(data[20:20 + n])
    offset = 20 + n
    _, kind = struct.unpack_from("<II", data, offset)
    if kind != _BIN:
        raise ValueError("the GLB's second chunk is not binary")
    blob = data[offset + 8:]
    primitive = doc["meshes"][0]["primitives"][0]
    if primitive.get("mode") != _LINES:
        raise ValueError("not a LINES primitive")
    accessor = doc["accessors"][primitive["attributes"]["POSITION"]]
    view = doc["bufferViews"][accessor["bufferView"]]
    points = np.frombuffer(blob, dtype=np.float32, count=3 * accessor["count"],
                           offset=view.get("byteOffset", 0) + accessor.get("byteOffset", 0))
    colour = linear_to_srgb(doc["materials"][primitive["material"]]["pbrMetallicRoughness"]["baseColorFactor"][:3])
    return points.reshape(-1, 2, 3).astype(np.float64), colour
