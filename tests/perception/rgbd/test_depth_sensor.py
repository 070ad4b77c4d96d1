"""The simulated depth sensor's errors (``manigraph_sim.physics.depth_noise``) and the
contract's depth image."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import DepthImage, message_type_for_key
from manigraph_sim.physics.depth_noise import (
    D400_SIGMA_PER_M2,
    DepthNoise,
    encode_depth_png,
    sensor_depth,
)


def _flat(distance: float, size: tuple[int, int] = (240, 320)) -> np.ndarray:
    return np.full((size[0] * 2, size[1] * 2), distance)


@pytest.mark.parametrize("distance", [0.5, 0.8, 1.2])
def test_noise_grows_with_the_square_of_the_distance(distance: float) -> None:
    noise = DepthNoise(edge_dropout=0, holes=0)
    depth = sensor_depth(_flat(distance), 2, noise, np.random.default_rng(0))
    expected = D400_SIGMA_PER_M2 * distance**2
    assert abs(depth.std() - expected) < 0.15 * expected + 0.0003  # + the 1 mm quantisation
    assert abs(depth.mean() - distance) < 0.0005


def test_doubled_noise_is_twice_as_large() -> None:
    single = sensor_depth(_flat(1.0), 2, DepthNoise(holes=0), np.random.default_rng(1))
    double = sensor_depth(_flat(1.0), 2, DepthNoise(2.0, holes=0), np.random.default_rng(1))
    assert 1.8 < double.std() / single.std() < 2.2


def test_edges_drop_out_holes_appear_and_nothing_is_out_of_range() -> None:
    fine = _flat(0.8)
    fine[:, 300:] = 0.7  # a step 10 cm nearer from column 150 of the output
    fine[:20] = 0.0  # nothing hit (sky)
    fine[-20:] = 4.0  # beyond the range
    depth = sensor_depth(fine, 2, DepthNoise(edge_dropout=1.0, holes=4), np.random.default_rng(2))
    assert (depth[20:-20, 149:151] == 0).all()  # the step's pixels
    assert (depth[:10] == 0).all() and (depth[-10:] == 0).all()
    middle = depth[20:-20, :140]
    assert 0 < (middle == 0).mean() < 0.2  # some holes, not many
    exact = sensor_depth(fine, 2, DepthNoise.none(), np.random.default_rng(2))
    assert set(np.unique(exact[20:-20])) == {0.7, 0.8}


def test_a_sensor_model_out_of_range_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="depth-noise"):
        DepthNoise(scale=-1)


def test_depth_travels_as_a_16_bit_png_of_millimetres() -> None:
    depth = sensor_depth(_flat(0.9), 2, DepthNoise(), np.random.default_rng(3))
    data = encode_depth_png(depth)
    message = DepthImage(camera="front", stamp=1.0, sequence=4, data=data)
    decoded = DepthImage.decode(message.encode())
    assert decoded == message
    assert message.key_for() == "manigraph/camera/front/depth"
    assert message_type_for_key("manigraph/camera/front/depth") is DepthImage
    millimetres = cv2.imdecode(np.frombuffer(decoded.data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert millimetres.dtype == np.uint16
    assert np.allclose(millimetres / 1000.0, depth, atol=1e-9)
    # A full frame of the noisy sensor fits the contract's limit (640 x 480).
    full = sensor_depth(_flat(0.9, (480, 640)), 2, DepthNoise(), np.random.default_rng(3))
    assert len(encode_depth_png(full)) < 700_000


def test_depth_without_the_camera_is_refused_by_name() -> None:
    from manigraph_sim.backends import create_backend

    with pytest.raises(ConfigError, match="camera-depth: renders the camera's depth"):
        create_backend("physics", camera_depth=True)
