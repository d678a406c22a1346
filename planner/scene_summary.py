"""Text summary of a scene graph, for people and language models.

Short and bounded: a header (object count, robot pose), then the objects outside groups nearest
first (at most :data:`MAX_OBJECT_LINES`; the rest are counted by label), then the groups (at most
:data:`MAX_GROUP_LINES`), then the map's uncertainties (at most :data:`MAX_UNCERTAIN_LINES`). Each
object line states at most :data:`MAX_RELATIONS` relations, chosen in the order support,
behind, next to, in front of, left / right. The whole text never exceeds :data:`MAX_CHARS`
characters, whatever the number of objects. Input: the dict of
:func:`planner.scene_graph.build_scene_graph` (world frame, metres), version 2 or 1 (a version-1
graph has no ``placement``: it is worked out from ``bottom``, ``on`` and the workspace floor).

An object's placement is worded by its sign: ``floating 0.44 m above the floor`` only for a
positive gap with nothing under it; an object whose bottom is below the floor is ``sunk 0.44 m
into the floor`` (or ``entirely below the floor``), a mapping error, never "floating".
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from planner.scene_graph import placement

MAX_OBJECT_LINES = 12
MAX_GROUP_LINES = 5
MAX_UNCERTAIN_LINES = 5
MAX_RELATIONS = 3
MAX_CHARS = 3000

_REL_ORDER = ("on_top_of", "under", "behind", "next_to", "in_front_of", "left_of", "right_of")
_REL_TEXT = {"on_top_of": "on top of", "under": "under", "behind": "behind", "next_to": "next to",
             "in_front_of": "in front of", "left_of": "left of", "right_of": "right of"}


def plural(word: str) -> str:
    """English plural of a label word (``box`` -> ``boxes``, ``chair`` -> ``chairs``)."""
    if word.endswith(("s", "x", "ch", "sh", "z")):
        return word + "es"
    if word.endswith("y") and len(word) > 1 and word[-2] not in "aeiou":
        return word[:-1] + "ies"
    return word + "s"


def nice(label: str) -> str:
    """A label as words (``robot_dog`` -> ``robot dog``)."""
    return label.replace("_", " ")


def _xy(p: Any) -> str:
    return f"({p[0]:.2f}, {p[1]:.2f})"


def _group_name(g: dict[str, Any]) -> str:
    n = len(g["members"])
    what = plural(nice(g["label"]))
    return f"the {g['kind']} of {n} {what}"


def _names(graph: dict[str, Any]) -> dict[str, str]:
    out = {o["id"]: f"{nice(o['label'])} ({o['id']})" for o in graph["objects"]}
    out.update({g["id"]: f"{_group_name(g)} ({g['id']})" for g in graph["groups"]})
    return out


def _reach_text(o: dict[str, Any]) -> str:
    r = o.get("reach")
    if r is None:
        return ""
    if r["mode"] == "walk":
        return "reachable by walking" + (" (the cheapest path flies part of the way)" if r["planned"] == "walk+fly" else "")
    if r["mode"] == "fly":
        land = f"; lands at {_xy(r['landing'])}" if r.get("landing") else ""
        return f"reachable only by flying (goal {_xy(r['goal'])}{land})"
    if r["mode"] == "none":
        return f"unreachable: {r['reason']}"
    return "reachability unknown"


def _placement(o: dict[str, Any], floor: float) -> tuple[str, float]:
    """``(placement, floor_gap [m])`` of an object record; worked out for a version-1 record."""
    if "placement" in o:
        return o["placement"], o["floor_gap"]
    gap = o["bottom"] - floor
    return placement(o["on"], gap), gap


def _placement_bit(kind: str, gap: float, height: float) -> str:
    if kind == "on_floor":
        return "on the floor"
    if kind == "floating":
        return f"floating {gap:.2f} m above the floor"
    if kind == "below_floor":
        if -gap >= height:
            return f"entirely below the floor, its bottom {-gap:.2f} m under it (a mapping error?)"
        return f"sunk {-gap:.2f} m into the floor (a mapping error?)"
    return ""  # on an object: said by its on_top_of relation


def _floor(graph: dict[str, Any]) -> float:
    ws = graph.get("workspace")
    return float(ws["min"][2]) if ws else 0.0


def _object_line(o: dict[str, Any], rels: list[tuple[str, str]], names: dict[str, str], floor: float = 0.0) -> str:
    parts = [f"{nice(o['label'])} ({o['id']})"]
    fr = o.get("from_robot")
    head = f"- {parts[0]}: " + (f"{fr['distance']:.1f} m {fr['direction']}" if fr else _xy(o["centre"]))
    bits = []
    kind, gap = _placement(o, floor)
    where = _placement_bit(kind, gap, o["top"] - o["bottom"])
    if where:
        bits.append(where)
    rels = sorted(rels, key=lambda r: (_REL_ORDER.index(r[0]), not r[1].startswith("group-"), r[1]))
    said = 0
    for kind, other in rels:
        if said >= MAX_RELATIONS:
            break
        text = f"{_REL_TEXT[kind]} {names.get(other, other)}"
        if kind == "behind" and o.get("visibility") == "hidden" and not any(b.startswith("hidden") for b in bits):
            text = "hidden " + text
        bits.append(text)
        said += 1
    if o.get("visibility") == "hidden" and not any(k == "behind" for k, _ in rels[:said]):
        bits.append("hidden from the robot")
    elif o.get("visibility") == "partly_hidden":
        bits.append("partly hidden")
    reach = _reach_text(o)
    if reach:
        bits.append(reach)
    unsure = [u for u in o["uncertain"] if not _restates_placement(u)]  # the placement is said above
    if unsure:
        bits.append("uncertain: " + ", ".join(unsure[:2]))
    return head + "; " + "; ".join(bits) + "."


def _restates_placement(text: str) -> bool:
    return text.startswith(("seems to float ", "sunk ", "lies entirely below the floor", "floating"))


def _group_line(g: dict[str, Any], graph: dict[str, Any], names: dict[str, str]) -> str:
    mem = g["members"]
    objs = {o["id"]: o for o in graph["objects"]}
    first = f"{mem[0]} … {mem[-1]}" if len(mem) > 2 else ", ".join(mem)
    line = (f"- {_group_name(g)} ({g['id']}: {first}): {g['length']:.2f} m long, {g['height']:.2f} m high")
    frs = [objs[m]["from_robot"] for m in mem if objs[m].get("from_robot")]
    if frs:
        near = min(frs, key=lambda f: f["nearest"])
        line += f", {near['nearest']:.1f} m {near['direction']} at its nearest"
    if g["crosses_workspace"]:
        line += "; it crosses the workspace wall to wall"
    beyond = sorted(r["subject"] for r in graph["relations"] if r["relation"] == "behind" and r["object"] == g["id"])
    if beyond:
        shown = ", ".join(names.get(b, b) for b in beyond[:4]) + (f" and {len(beyond) - 4} more" if len(beyond) > 4 else "")
        line += f"; behind it: {shown}"
    modes = Counter((objs[m].get("reach") or {}).get("mode") for m in mem)
    if modes and None not in modes:
        words = {"walk": "by walking", "fly": "only by flying", "none": "not at all", "unknown": "unknown"}
        line += "; members reachable " + ", ".join(f"{words[k]} ({v})" for k, v in sorted(modes.items()))
    return line + "."


def summarize(graph: dict[str, Any]) -> str:
    """The bounded text summary of a scene graph (see the module docstring)."""
    objs = graph["objects"]
    names = _names(graph)
    lines = []
    robot = graph.get("robot")
    head = f"Scene (world frame, metres): {len(objs)} object{'' if len(objs) == 1 else 's'}"
    if graph["groups"]:
        n = len(graph["groups"])
        head += f", {n} group{'' if n == 1 else 's'}"
    if robot:
        p = robot["position"]
        head += f". Robot at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) heading {robot['yaw_deg']:.0f}° (world, from +x)"
    else:
        head += ". Robot pose unknown (give one for distances, directions and reachability)"
    lines.append(head + ".")
    if not objs:
        lines.append("The map is empty: nothing has been mapped yet.")
        return "\n".join(lines)
    rels: dict[str, list[tuple[str, str]]] = {}
    for r in graph["relations"]:
        rels.setdefault(r["subject"], []).append((r["relation"], r["object"]))
        if r["relation"] == "next_to":  # symmetric, listed once in the graph
            rels.setdefault(r["object"], []).append((r["relation"], r["subject"]))
    single = [o for o in objs if o["group"] is None]
    single.sort(key=lambda o: (o["from_robot"]["distance"] if o.get("from_robot") else 0.0, o["id"]))
    if single:
        lines.append("Objects, nearest first:" if robot else "Objects:")
        for o in single[:MAX_OBJECT_LINES]:
            lines.append(_object_line(o, rels.get(o["id"], []), names, _floor(graph)))
        rest = single[MAX_OBJECT_LINES:]
        if rest:
            counts = Counter(nice(o["label"]) for o in rest)
            what = ", ".join(f"{n} {plural(k) if n > 1 else k}" for k, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))[:6])
            far = (f" (from {rest[0]['from_robot']['distance']:.1f} m)" if rest[0].get("from_robot") else "")
            lines.append(f"- and {len(rest)} more{far}: {what}" + (", ..." if len(counts) > 6 else "") + ".")
    if graph["groups"]:
        lines.append("Groups:")
        for g in graph["groups"][:MAX_GROUP_LINES]:
            lines.append(_group_line(g, graph, names))
        if len(graph["groups"]) > MAX_GROUP_LINES:
            more = len(graph["groups"]) - MAX_GROUP_LINES
            lines.append(f"- and {more} more group{'' if more == 1 else 's'}.")
    unc = graph["uncertainties"]
    if unc:
        lines.append("Uncertain:")
        lines += [f"- {u}" for u in unc[:MAX_UNCERTAIN_LINES]]
        if len(unc) > MAX_UNCERTAIN_LINES:
            lines.append(f"- and {len(unc) - MAX_UNCERTAIN_LINES} more.")
    text = "\n".join(lines)
    if len(text) > MAX_CHARS:
        cut = text[: MAX_CHARS - 40].rsplit("\n", 1)[0]
        text = cut + "\n(summary cut to stay short)"
    return text


__all__ = ["MAX_CHARS", "MAX_GROUP_LINES", "MAX_OBJECT_LINES", "MAX_RELATIONS", "nice", "plural", "summarize"]
