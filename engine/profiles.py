"""Rig profiles: how a foreign skeleton's joints map to the roles the engine needs.

A profile (a JSON file in ``assets/profiles/``) names, for one family of
skeletons, which joint plays which role (hips, spine chain, clavicles, arm,
forearm, roll joints where present, hand, legs, feet), the file's units (the
scale to cm), the up axis, the performer's handedness and the implement (bat,
club). The engine never names a joint in code: everything here is data.

:func:`detect` picks a profile from the joint names; :func:`resolve` places
each role on a joint index and refuses, in one line, a skeleton it cannot place.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from .rig import assets_dir
from .skeleton import Skeleton

SIDES = ("left", "right")
LIMB_ROLES = ("clavicle", "arm", "arm_roll", "forearm", "forearm_roll", "hand", "upleg", "leg", "foot", "toe")
REQUIRED = ("hips", "spine") + tuple(f"{s}_{r}" for s in SIDES for r in ("arm", "forearm", "hand"))
OPTIONAL_IN_FILE = tuple(f"{s}_{r}" for s in SIDES for r in ("arm_roll", "forearm_roll", "toe"))
HIT_POINTS = ("hands_midpoint", "along_hands")
# where a profile directory holds this many files, something is wrong
MAX_PROFILES = 64


class ProfileError(ValueError):
    """A skeleton that does not fit a profile, or a malformed profile; one line."""


@dataclass
class Profile:
    name: str
    description: str
    roles: dict                      # role -> joint name (or pattern), spine/neck -> list or "path"
    scale_cm: float | str = 1.0      # cm per file unit, or "auto" (from the body's height)
    up: str = "y"
    handedness: str = "right"        # right-handed performer: the left hand leads
    signature: list[str] = field(default_factory=list)  # names that must exist for auto-detection
    prefix: str = ""                 # a regex stripped from the start of every joint name
    patterns: bool = False           # roles are regexes over normalised names
    implement: dict = field(default_factory=dict)

    @property
    def lead(self) -> str:
        """The side whose hand leads (top of the handle): left for a right-hander."""
        return "left" if self.handedness == "right" else "right"

    @property
    def trail(self) -> str:
        return "right" if self.lead == "left" else "left"


def profiles_dir() -> Path:
    return assets_dir() / "profiles"


def _check(data: dict, where: str) -> Profile:
    if not isinstance(data, dict) or not isinstance(data.get("roles"), dict):
        raise ProfileError(f"{where}: expected an object with 'name' and 'roles'")
    known = {"name", "description", "roles", "scale_cm", "up", "handedness", "signature", "prefix",
             "patterns", "implement"}
    extra = sorted(set(data) - known)
    if extra:
        raise ProfileError(f"{where}: unknown key {extra[0]!r} (known: {', '.join(sorted(known))})")
    p = Profile(**{k: data[k] for k in known if k in data})
    if p.handedness not in ("right", "left"):
        raise ProfileError(f"{where}: handedness must be 'right' or 'left', got {p.handedness!r}")
    if p.up not in ("y", "z"):
        raise ProfileError(f"{where}: up must be 'y' or 'z', got {p.up!r}")
    if p.scale_cm != "auto" and not (isinstance(p.scale_cm, (int, float)) and 1e-4 <= p.scale_cm <= 1e4):
        raise ProfileError(f"{where}: scale_cm must be a number in [1e-4, 1e4] or 'auto'")
    hp = p.implement.get("hit_point", "hands_midpoint")
    if "joint" not in p.implement and hp not in HIT_POINTS:
        raise ProfileError(f"{where}: implement hit_point must be one of {', '.join(HIT_POINTS)}")
    unknown = sorted(set(p.roles) - set(REQUIRED) - {"neck", "head"} -
                     {f"{s}_{r}" for s in SIDES for r in LIMB_ROLES})
    if unknown:
        raise ProfileError(f"{where}: unknown role {unknown[0]!r}")
    return p


def load_profile(name_or_path: str | Path) -> Profile:
    """A bundled profile by name, or a profile JSON file by path."""
    path = Path(name_or_path)
    if path.suffix.lower() != ".json":
        path = profiles_dir() / f"{name_or_path}.json"
        if not path.is_file():
            raise ProfileError(f"unknown profile {str(name_or_path)!r} (known: {', '.join(profile_names())})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ProfileError(f"{path.name}: cannot read the profile ({e.__class__.__name__})") from None
    return _check(data, path.name)


def profile_names() -> list[str]:
    """Bundled profiles, named ones first and 'generic' last (the auto-detection order)."""
    names = sorted(p.stem for p in profiles_dir().glob("*.json"))[:MAX_PROFILES]
    return [n for n in names if n != "generic"] + (["generic"] if "generic" in names else [])


def _normalised(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.rsplit(":", 1)[-1].lower())


def _stripped(profile: Profile, names: list[str]) -> list[str]:
    if not profile.prefix:
        return list(names)
    pat = re.compile(profile.prefix)
    return [pat.sub("", n, count=1) if pat.match(n) else n for n in names]


def _place(profile: Profile, names: list[str], role: str, spec) -> int | None:
    if profile.patterns:
        pat = re.compile(spec)
        hits = [i for i, n in enumerate(names) if pat.fullmatch(_normalised(n))]
        return hits[0] if hits else None
    return names.index(spec) if spec in names else None


def _path(skeleton: Skeleton, top: int, bottom: int) -> list[int]:
    """Joints strictly below ``top`` down to ``bottom`` inclusive (root-most first)."""
    path, j = [], bottom
    while j != top and j >= 0:
        path.append(j)
        j = int(skeleton.parents[j])
    return path[::-1] if j == top else []


def _structural(profile: Profile, skeleton: Skeleton, roles: dict) -> list[str]:
    """Spine and neck given as 'path': the joints between the hips, the shoulders and the head."""
    missing = []
    if profile.roles.get("spine") == "path":
        below = roles.get("left_clavicle", roles.get("left_arm"))
        roles["spine"] = [] if below is None or "hips" not in roles else \
            _path(skeleton, roles["hips"], int(skeleton.parents[below]))
    if profile.roles.get("neck") == "path":
        head = roles.get("head")
        roles["neck"] = [] if head is None or not roles.get("spine") else \
            _path(skeleton, roles["spine"][-1], head)[:-1]
    if not roles.get("spine"):
        missing.append("spine")
    return missing


def resolve(profile: Profile, skeleton: Skeleton) -> dict:
    """Role -> joint index (``spine``/``neck``: lists, root-most first).

    Raises :class:`ProfileError` naming the roles that could not be placed and
    the joints the profile names but the file lacks."""
    names = _stripped(profile, skeleton.names)
    roles, lacking, unplaced = {}, [], []
    for role, spec in profile.roles.items():
        if spec == "path":
            continue
        if isinstance(spec, list):
            idx = [names.index(n) if n in names else None for n in spec]
            lacking += [n for n, i in zip(spec, idx) if i is None]
            roles[role] = [i for i in idx if i is not None]
            continue
        i = _place(profile, names, role, spec)
        if i is None and not (profile.patterns or role in OPTIONAL_IN_FILE):
            lacking.append(spec)
        elif i is None:
            unplaced.append(role)
        else:
            roles[role] = i
    missing = _structural(profile, skeleton, roles) if not lacking else []
    missing += [r for r in REQUIRED if r not in roles and r not in missing]
    if lacking:
        raise ProfileError(f"profile {profile.name!r} names joints the file lacks: {', '.join(lacking[:6])}")
    if missing:
        raise ProfileError(f"profile {profile.name!r}: could not place {', '.join(missing)}")
    _check_limbs(profile, skeleton, roles)
    return roles


def _check_limbs(profile: Profile, skeleton: Skeleton, roles: dict) -> None:
    """Each arm runs spine -> clavicle -> arm -> forearm -> hand, each below the one before."""
    for side in SIDES:
        order = [roles["spine"][0]] + [roles[f"{side}_{r}"] for r in ("clavicle", "arm", "arm_roll", "forearm",
                                                                        "forearm_roll", "hand") if f"{side}_{r}" in roles]
        for a, b in zip(order, order[1:]):
            if not _path(skeleton, a, b):
                raise ProfileError(f"profile {profile.name!r}: joint {skeleton.names[b]!r} is not below "
                                   f"{skeleton.names[a]!r} (the {side} arm's order)")


def _fits_signature(profile: Profile, skeleton: Skeleton) -> bool:
    if profile.prefix:
        pat = re.compile(profile.prefix)
        if sum(bool(pat.match(n)) for n in skeleton.names) * 2 < skeleton.num_joints:
            return False
    names = set(_stripped(profile, skeleton.names))
    return all(n in names for n in profile.signature)


def detect(skeleton: Skeleton) -> tuple[Profile, dict]:
    """The first bundled profile whose signature and roles fit (generic last), and its roles."""
    reasons = []
    for name in profile_names():
        profile = load_profile(name)
        if not _fits_signature(profile, skeleton):
            continue
        try:
            return profile, resolve(profile, skeleton)
        except ProfileError as e:
            reasons.append(str(e).split(": ", 1)[-1])
    placed = set()
    try:
        placed = set(_flat(resolve_loose(skeleton)))
    except ProfileError:
        pass
    left = [n for i, n in enumerate(skeleton.names) if i not in placed][:8]
    why = f" ({reasons[-1]})" if reasons else ""
    raise ProfileError(f"the skeleton fits no profile ({', '.join(profile_names())}){why}; "
                       f"joints not placed: {', '.join(left) or '-'}")


def resolve_loose(skeleton: Skeleton) -> dict:
    """The generic profile's roles, for messages (what could be placed at all)."""
    generic = load_profile("generic")
    names = _stripped(generic, skeleton.names)
    roles = {r: i for r, s in generic.roles.items() if s != "path"
             for i in [_place(generic, names, r, s)] if i is not None}
    _structural(generic, skeleton, roles)
    return roles


def _flat(roles: dict) -> list[int]:
    return [j for v in roles.values() for j in (v if isinstance(v, list) else [v])]
