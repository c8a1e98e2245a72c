"""A user's own shot library: a folder of BVH captures on one skeleton, with a
manifest (``library.json``) naming each shot, its hit frame and its profile.

``init_library`` writes the manifest for a folder (hit frames found or given);
``load_shots`` loads the bundled library or a user's, as ``(rig, shots)`` —
one rig for every shot, so a library mixing skeletons is refused.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from . import atomic, bvh
from .capture import Capture, load_capture
from .library import MAX_SHOTS, LibraryError, Shot, load_library, read_manifest
from .rig import Rig, default_rig

MANIFEST = "library.json"
SAME_OFFSET_CM = 0.01      # two skeletons are the same when every bone agrees this closely


def manifest_path(library: str | Path) -> Path:
    """The manifest of a library given as a folder or as its manifest file."""
    p = Path(library)
    return p / MANIFEST if p.is_dir() else p


def _same_skeleton(a: Capture, b: Capture) -> str | None:
    """Why two captures are not on one skeleton (None when they are)."""
    sa, sb = a.file_skeleton, b.file_skeleton
    if sa.names != sb.names:
        extra = sorted(set(sb.names) ^ set(sa.names))
        return f"joints differ ({', '.join(extra[:3]) or 'order'})"
    bone = np.abs(sa.offsets * a.scale - sb.offsets * b.scale).max(axis=1)
    worst = int(np.argmax(bone))
    if bone[worst] > SAME_OFFSET_CM:
        return f"bone {sa.names[worst]!r} differs by {bone[worst]:.2f} cm"
    if a.profile.name != b.profile.name or a.profile.handedness != b.profile.handedness:
        return f"profiles differ ({a.profile.name}, {b.profile.name})"
    return None


def _one_rig(captures: list[Capture], where: str) -> tuple[Rig, list[Shot]]:
    """Every capture on the first one's rig; the implement placed once for all
    (the median of each shot's own placement: a grip hardly moves in the hand)."""
    first = captures[0]
    for c in captures[1:]:
        why = _same_skeleton(first, c)
        if why:
            raise LibraryError(Path(where), f"shots on different skeletons: {first.path.name} and {c.path.name} "
                               f"({why}); a library holds one skeleton")
    rig = first.rig
    if first.appended:
        offset = np.median([c.rig.skeleton.offsets[-1] for c in captures], axis=0)
        rig.skeleton.offsets[-1] = offset
        for c in captures:
            if c.shot.clip.local_positions is not None:
                c.shot.clip.local_positions[:, -1] = offset
    shots = [replace(c.shot, skeleton=rig.skeleton, bat_joint=rig.bat_joint, capture=c) for c in captures]
    return rig, shots


def load_user_library(library: str | Path) -> tuple[Rig, list[Shot], list[Capture]]:
    """A user's library: its rig, its shots (cm) and the captures (to write results back)."""
    manifest = manifest_path(library)
    entries = read_manifest(manifest)
    captures = []
    for i, e in enumerate(entries):
        if e.profile is None:
            raise LibraryError(manifest, "no 'profile' (a library of captures names each shot's rig profile; "
                               "hitpoint library init writes it)", i)
        try:
            c = load_capture(e.path, e.profile, e.hit_frame, facing=e.facing)
        except ValueError as err:
            raise LibraryError(manifest, f"{e.file}: {err}", i) from None
        c.shot = replace(c.shot, name=e.name, description=e.description or c.shot.description)
        captures.append(c)
    rig, shots = _one_rig(captures, str(manifest))
    return rig, shots, captures


def _is_bundled_manifest(manifest: Path) -> bool:
    try:
        return all(e.profile is None for e in read_manifest(manifest))
    except LibraryError:
        return False


def load_shots(library: str | Path | None = None) -> tuple[Rig, list[Shot]]:
    """The bundled library (``None``) or a user's: ``(rig, shots)``."""
    if library is None:
        rig = default_rig()
        return rig, load_library(rig=rig)
    manifest = manifest_path(library)
    if not manifest.is_file():
        raise LibraryError(manifest, f"no {MANIFEST} here (write one with: hitpoint library init {library})")
    if _is_bundled_manifest(manifest):
        rig = default_rig()
        return rig, load_library(manifest, rig=rig)
    rig, shots, _ = load_user_library(manifest)
    return rig, shots


def init_library(folder: str | Path, profile: str = "auto", hit_frame: int | str = "auto",
                 force: bool = False, facing: int | str = "auto") -> tuple[Path, list[dict]]:
    """Write ``folder/library.json`` for the folder's BVH files; returns it and its entries.

    Every file must read and fit the profile, and all must share one skeleton;
    an existing manifest is kept unless ``force``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise LibraryError(folder, "not a folder")
    out = folder / MANIFEST
    if out.exists() and not force:
        raise LibraryError(out, "exists already (give --force to write it again)")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".bvh" and p.is_file())
    if not files:
        raise LibraryError(folder, "no .bvh files in the folder")
    if len(files) > MAX_SHOTS:
        raise LibraryError(folder, f"{len(files)} BVH files is beyond {MAX_SHOTS} (MAX_SHOTS)")
    captures = []
    for f in files:
        try:
            captures.append(load_capture(f, profile, hit_frame, facing=facing))
        except (ValueError, bvh.BvhError) as err:
            text = str(err)
            raise LibraryError(folder, text if f.name in text else f"{f.name}: {text}") from None
    _one_rig(captures, str(out))
    entries = [{"name": c.path.stem[:64], "file": c.path.name, "hit_frame": c.hit.frame,
                "description": f"{c.profile.name} capture; hit frame: {c.hit.method}"
                               + (f"; turned {c.facing_deg} deg to face the ball" if c.facing_deg else ""),
                "profile": c.profile.name, "facing": c.facing_deg} for c in captures]
    atomic.write_text(out, json.dumps(entries, indent=1) + "\n")
    return out, entries
