"""What the stack tools consume and produce (see ``manigraph_shared.manifest``)."""

from manigraph_shared.manifest import Manifest, port
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    EpisodeEvent,
    EpisodeRequest,
    ExplainRequest,
    Scene,
    ServiceStatus,
    SkillStatus,
)

RECORDER = Manifest(service="recorder", summary="manigraph record: MCAP", observes_all=True)

EPISODE_CLIENT = Manifest(
    service="run",
    summary="manigraph run / up: episode client",
    consumes=(port(EpisodeEvent),),
    requests=(port(EpisodeRequest),),
)

EXPLAIN_CLIENT = Manifest(
    service="explain",
    summary="manigraph explain: why that decision",
    requests=(port(ExplainRequest),),
)

VIEW = Manifest(service="view", summary="manigraph view: Foxglove WebSocket", observes_all=True)

STOP = Manifest(
    service="stop",
    summary="manigraph stop / resume: emergency stop",
    produces=(port(EmergencyStop),),
)

DEMO_UI = Manifest(
    service="demo-ui",
    summary="manigraph demo-ui: a person clicks the decisions",
    consumes=(port(Scene), port(SkillStatus), port(EpisodeEvent)),
    produces=(port(Action), port(ServiceStatus)),
    requests=(port(EpisodeRequest),),
)
