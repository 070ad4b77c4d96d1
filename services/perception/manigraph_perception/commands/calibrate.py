"""``manigraph calibrate intrinsics|extrinsics``: write the calibration file perception reads."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from manigraph_shared.cli import Command


def _configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(
        dest="step", required=True, metavar="STEP", help="intrinsics, then extrinsics"
    )
    intrinsics = sub.add_parser(
        "intrinsics", help="camera matrix and distortion from ChArUco board images"
    )
    intrinsics.add_argument("images", nargs="+", type=Path, help="board images (4 or more)")
    intrinsics.add_argument("--squares", default="7x5", help="squares across x down (7x5)")
    intrinsics.add_argument("--square", type=float, default=0.04, help="square side, metres")
    intrinsics.add_argument("--marker", type=float, default=0.03, help="marker side, metres")
    intrinsics.add_argument(
        "--dictionary", default="DICT_4X4_50", help="OpenCV ArUco dictionary of the board's markers"
    )
    intrinsics.add_argument("-o", "--output", type=Path, required=True, help="YAML to write")
    extrinsics = sub.add_parser(
        "extrinsics", help="camera -> robot base from markers at known robot-frame positions"
    )
    extrinsics.add_argument("images", nargs="+", type=Path, help="images of the markers")
    extrinsics.add_argument(
        "--intrinsics", type=Path, required=True, help="YAML from calibrate intrinsics"
    )
    extrinsics.add_argument(
        "--points", type=Path, required=True, help="TOML: markers' robot-frame centres"
    )
    extrinsics.add_argument(
        "--affine",
        action="store_true",
        help="fit an affine map to the markers' centres (the paper's), not the camera's "
        "rigid pose to their corners",
    )
    extrinsics.add_argument(
        "-o", "--output", type=Path, help="YAML to write (default: add to --intrinsics)"
    )


def _read_grey(paths: list[Path]) -> list:
    import cv2

    from manigraph_shared.errors import ConfigError

    images = []
    for path in paths:
        grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if grey is None:
            raise ConfigError("images", f"cannot read '{path}' as an image")
        images.append(grey)
    return images


def _run(args: argparse.Namespace) -> int:
    import numpy as np

    from manigraph_perception.calibration_file import load_calibration
    from manigraph_perception.calibration_fit import (
        CharucoSpec,
        calibrate_intrinsics,
        fit_camera_pose,
        fit_transform,
        load_known_markers,
        observe_markers,
        residuals_mm,
    )
    from manigraph_shared.errors import ConfigError

    greys = _read_grey(args.images)
    if args.step == "intrinsics":
        try:
            squares_x, squares_y = (int(v) for v in args.squares.lower().split("x"))
        except ValueError:
            raise ConfigError("squares", f"'{args.squares}' is not like 7x5") from None
        spec = CharucoSpec(squares_x, squares_y, args.square, args.marker, args.dictionary)
        calibration, rms = calibrate_intrinsics(greys, spec)
        calibration.save(args.output)
        report = {"rms_px": round(rms, 4), "camera_matrix": calibration.camera_matrix.tolist()}
    else:
        calibration = load_calibration(args.intrinsics, need_extrinsics=False)
        dictionary, known = load_known_markers(args.points)
        if args.affine:
            camera, base = observe_markers(greys, calibration, dictionary, known)
            transform = fit_transform(camera, base, affine=True)
            residuals = residuals_mm(transform, camera, base)
        else:
            transform, residuals = fit_camera_pose(
                [(grey, known) for grey in greys], calibration, dictionary
            )
        calibration.base_T_camera = transform
        calibration.save(args.output or args.intrinsics)
        report = {
            "points": len(residuals),
            "fit": "affine (marker centres)" if args.affine else "rigid (PnP on corners)",
            "residual_mm_median": round(float(np.median(residuals)), 3),
            "residual_mm_max": round(float(residuals.max()), 3),
        }
    print(json.dumps(report))
    return 0


command = Command(
    help="calibrate a camera: intrinsics (ChArUco) or extrinsics (markers at known positions)",
    configure=_configure,
    run=_run,
)
