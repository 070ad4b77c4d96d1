"""The teacher with rules only it and the judge know (``--rules``, docs/task-files.md).

:class:`RuledTeacher` wraps an expert: it decides on the Scene as the rules see it (each goal's
``accepts`` judged by them, ``manigraph_shared.rules``), so its demonstrations follow the rules,
while the Scene it was given, the one recorded beside its Action, is left as it was. Only a
teacher takes rules: a learned policy has to learn them from the demonstrations.
"""

from __future__ import annotations

from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import Scene
from manigraph_shared.rules import TeacherRules

#: Policies that may be told the rules: the expert that demonstrates any task file.
TEACHERS = ("expert",)


class RuledTeacher(Policy):
    """``teacher``'s decisions on each Scene as ``rules`` see it."""

    def __init__(self, teacher: Policy, rules: TeacherRules) -> None:
        self.teacher = teacher
        self.rules = rules
        self.name = teacher.name
        self.object_escalation = teacher.object_escalation

    def decide(self, scene: Scene) -> Decision | None:
        return self.teacher.decide(self.rules.apply(scene))

    def ranked(self, scene: Scene) -> list[Decision]:
        return self.teacher.ranked(self.rules.apply(scene))


def with_rules(policy: Policy, text: str | None, source: str = "rules file") -> Policy:
    """``policy`` told the rules of ``text`` (None: as it is); ``PolicyError`` for a policy
    that is not a teacher (:data:`TEACHERS`)."""
    if text is None:
        return policy
    if policy.name not in TEACHERS:
        raise PolicyError(
            f"rules: only the teacher ({', '.join(TEACHERS)}) is told the rules; "
            f"{policy.name} has to learn them from its demonstrations"
        )
    return RuledTeacher(policy, TeacherRules.from_text(text, source))
