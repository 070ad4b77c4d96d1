#!/usr/bin/env bash
# Regenerate the golden logs in tests/golden/: one recorded episode per shipped checkpoint,
# driven through the full stack. Run this only when a change of decisions is intended, and
# say why in the commit; tests/regression/test_golden_logs.py compares against these files.
# Scenes travel "latest only", so a busy machine can keep one from the recorder; a log that
# lacks a scene some decision was taken on is recorded again (up to three times).
set -euo pipefail
cd "$(dirname "$0")/.."
run() { python3 -m uv run --frozen --all-packages "$@"; }
# The regression test itself checks a fresh log: every decision's scene is there.
complete() {
    run pytest -q \
        "tests/regression/test_golden_logs.py::test_policy_takes_the_recorded_decision_on_every_recorded_scene[$1]"
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
            if complete "$arch-$1$2" > /dev/null; then break; fi
            [ "$attempt" -lt 3 ] || exit 1
        done
    done
done
