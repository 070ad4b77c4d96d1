#!/usr/bin/env bash
# Regenerate the golden logs in tests/golden/: one recorded episode per shipped checkpoint,
# driven through the full stack. Run this only when a change of decisions is intended, and
# say why in the commit; tests/regression/test_golden_logs.py compares against these files.
# Scenes travel "latest only", so a busy machine can keep one from the recorder; a log that
# lacks a scene some decision was taken on is recorded again (up to three times).
set -euo pipefail
cd "$(dirname "$0")/.."
run() { python3 -m uv run --frozen --all-packages "$@"; }
complete() {
    run python - "$1" <<'PY'
import sys
from pathlib import Path
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Scene
log = Path(sys.argv[1])
scenes = [Scene.decode(item.data) for item in read_log(log, [Scene.key])]
seen = {(scene.episode_id, scene.sequence) for scene in scenes}
actions = [Action.decode(item.data) for item in read_log(log, [Action.key])]
missing = [a.scene_sequence for a in actions if (a.episode_id, a.scene_sequence) not in seen]
if missing:
    sys.exit(f"{log}: no scene {missing} in the log")
PY
}
mkdir -p tests/golden
for arch in gcn sage gated gat; do
    for case in "stack 4" "pyramid 6"; do
        set -- $case
        log="tests/golden/$arch-$1$2.mcap"
        for attempt in 1 2 3; do
            rm -f "$log"
            run manigraph up --policy "checkpoints/$arch.pt" --task "$1" --blocks "$2" \
                --episodes 1 --seed 0 --port 17901 --record "$log" | tail -n 1 | cut -c1-120
            if complete "$log"; then break; fi
            [ "$attempt" -lt 3 ] || exit 1
        done
    done
done
