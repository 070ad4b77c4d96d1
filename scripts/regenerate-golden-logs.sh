#!/usr/bin/env bash
# Regenerate the golden logs in tests/golden/: one recorded episode per shipped checkpoint,
# driven through the full stack. Run this only when a change of decisions is intended, and
# say why in the commit; tests/regression/test_golden_logs.py compares against these files.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p tests/golden
for arch in gcn sage gated gat; do
    for case in "stack 4" "pyramid 6"; do
        set -- $case
        log="tests/golden/$arch-$1$2.mcap"
        rm -f "$log"
        python3 -m uv run --frozen --all-packages manigraph up --policy "checkpoints/$arch.pt" \
            --task "$1" --blocks "$2" --episodes 1 --seed 0 --port 17901 --record "$log" \
            | tail -n 1 | cut -c1-120
    done
done
