"""What the planner service consumes and produces (see ``manigraph_shared.manifest``)."""

from manigraph_shared.manifest import Manifest, port
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    EpisodeEvent,
    ExplainRequest,
    Explanation,
    Scene,
    ServiceStatus,
    SkillStatus,
)

MANIFEST = Manifest(
    service="planner",
    summary="policy: expert / GNN",
    consumes=(port(EmergencyStop), port(Scene), port(SkillStatus), port(EpisodeEvent)),
    produces=(port(Action), port(Explanation), port(ServiceStatus)),
    serves=(port(ExplainRequest),),
)
