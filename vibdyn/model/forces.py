"""Force-element groups: each kind of element a scene has, compiled into one numpy evaluation of all its
members (the kinds and their groups are declared in :mod:`vibdyn.description.elements`, one module each).
"""

from ..description.elements import KINDS


def compile_groups(system, scene):
    """The groups of the kinds this scene has, in the registry's order (kinds without a force: none)."""
    groups = []
    for kind in KINDS.values():
        members = scene.elements_of(kind)
        if members and kind.group is not None:
            group = kind.group(system, members)
            group.members = tuple(e.name for e in members)
            groups.append(group)
    return groups
