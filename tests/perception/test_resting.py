"""A resting block's depth from what it rests on (resting.py), and the world model using it."""

from __future__ import annotations

import numpy as np

from manigraph_perception.resting import RestConfig, Support, rest_on_support

CAMERA = np.array([0.92, 0.0, 0.45])  # the sim's tripod
CONFIG = RestConfig()


def _along_ray(point: np.ndarray, metres: float) -> np.ndarray:
    ray = (point - CAMERA) / np.linalg.norm(point - CAMERA)
    return point + metres * ray


def test_a_block_measured_too_far_along_the_ray_is_put_back_on_the_table() -> None:
    truth = np.array([0.4, 0.1, 0.02])
    measured = _along_ray(truth, 0.025)  # what a blurred 15-px marker does
    rested = rest_on_support(measured, CAMERA, 0.02, [Support(0.0)], [], CONFIG)
    assert rested is not None
    assert np.linalg.norm(rested - truth) < 1e-9


def test_a_block_rests_on_the_block_under_it_not_on_the_table() -> None:
    truth = np.array([0.5, -0.2, 0.06])
    below = np.array([0.505, -0.2, 0.02])
    supports = [Support(0.0), Support(0.04, (0.505, -0.2), (0.025, 0.025))]
    measured = _along_ray(truth, -0.015)
    rested = rest_on_support(measured, CAMERA, 0.02, supports, [below], CONFIG)
    assert rested is not None
    assert np.linalg.norm(rested - truth) < 1e-9


def test_a_spot_taken_by_another_block_is_not_a_place_to_rest() -> None:
    taken = np.array([0.45, 0.1, 0.02])
    measured = _along_ray(taken + np.array([0.005, 0.0, 0.0]), -0.02)
    assert rest_on_support(measured, CAMERA, 0.02, [Support(0.0)], [], CONFIG) is not None
    assert rest_on_support(measured, CAMERA, 0.02, [Support(0.0)], [taken], CONFIG) is None


def test_a_block_in_the_air_keeps_its_measured_pose() -> None:
    measured = np.array([0.5, 0.0, 0.2])  # held by the gripper, nothing near under it
    assert rest_on_support(measured, CAMERA, 0.02, [Support(0.0)], [], CONFIG) is None


def test_a_box_floor_holds_what_is_inside_it_and_the_table_does_not() -> None:
    floor = Support(0.01, (0.5, 0.2), (0.06, 0.06))
    truth = np.array([0.5, 0.2, 0.03])
    measured = _along_ray(truth, 0.01)
    rested = rest_on_support(measured, CAMERA, 0.02, [Support(0.0), floor], [], CONFIG, [floor])
    assert rested is not None
    assert np.linalg.norm(rested - truth) < 1e-9
