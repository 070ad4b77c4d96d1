#!/usr/bin/env bash
# Regenerate the shipped checkpoints: the paper's default protocol (20 expert box
# packing/unpacking demonstrations, K = 3, 4), one policy per architecture, seed 0.
#   scripts/train-shipped-checkpoints.sh [SEED]
set -euo pipefail
cd "$(dirname "$0")/.."
seed="${1:-0}"
run() { python3 -m uv run --frozen --all-packages "$@"; }
run manigraph demos -o data/demos.mcap --trajectories 20 --seed 0
for arch in gcn sage gated gat; do
    run manigraph train data/demos.mcap --arch "$arch" --seed "$seed" -o "checkpoints/$arch.pt"
done
