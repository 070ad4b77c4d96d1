"""A camera on a tripod in the physics world, rendered by SAPIEN, and the ArUco markers
printed on the bodies it looks at.

The tripod stands in front of the table (opposite the robot) and above it, like the paper's
hardware camera, 640 x 480 with a 60 degree vertical field of view. Rendering needs a Vulkan
device (Mesa lavapipe on CPU, ``scripts/install-vulkan.sh``): the first frame of a process
compiles shaders (~10-30 s), later ones take ~0.1-0.3 s on a busy 2-core machine.

With ``depth`` set, every frame also renders depth (metres along the optical axis) through a
stereo sensor's errors (``depth_noise.py``: a RealSense D400's noise growing with distance
squared, edge dropout, holes) into a ``DepthImage`` of the same ``sequence``. ``light_scale``
changes the lighting; ``pose_error`` (metres, degrees) stands the camera off its nominal pose
in a direction drawn from ``seed``, while ``CameraInfo`` and :func:`ideal_calibration` still
give the nominal one, as a calibration that has drifted would.

Frames are encoded (JPEG by default) into ``CompressedImage`` messages; ``CameraInfo``
carries the rendered camera's exact intrinsics (no distortion); :func:`ideal_calibration`
gives them with its exact pose, the ground truth the calibration commands are checked against
(``examples/calibration/sim-front.yaml``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import sapien

from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import MarkerMap, MarkerSpec, marker_in_object
from manigraph_shared.messages import CameraInfo, CompressedImage, DepthImage, ImageFormat
from manigraph_shared.rotations import rotation_matrix
from manigraph_sim.physics.depth_noise import DepthNoise, encode_depth_png, sensor_depth
from manigraph_sim.physics.render_targets import default_shaders, picture_rgb
from manigraph_sim.physics.video import look_at

#: Tripod in front of the table and above it, looking at the middle of the workspace.
TRIPOD_EYE = (0.92, 0.0, 0.45)
TRIPOD_TARGET = (0.5, 0.0, 0.02)
#: Pixels per marker cell in the printed textures (a 4x4 marker is 6 cells with its border).
_CELL_PIXELS = 16


@dataclass(frozen=True)
class CameraConfig:
    """The rendered camera: where it stands, its image, and how often it is published."""

    name: str = "front"
    width: int = 640
    height: int = 480
    fovy_degrees: float = 60.0
    eye: tuple[float, float, float] = TRIPOD_EYE
    target: tuple[float, float, float] = TRIPOD_TARGET
    hz: float = 2.0
    format: ImageFormat = ImageFormat.JPEG
    jpeg_quality: int = 95
    #: Image noise: Gaussian, this many grey levels (0: none), and motion blur length (px).
    noise_sigma: float = 0.0
    blur_pixels: int = 0
    seed: int = 0
    #: Rendered at this many times the size and averaged down: a real sensor integrates
    #: light over each pixel, so edges fall between pixels as they should (subpixel corners).
    supersample: int = 2
    #: Render depth through this sensor model too (None: colour only).
    depth: DepthNoise | None = None
    #: Print the ArUco markers on the bodies (off: plain coloured bodies, for RGB-D).
    markers: bool = True
    #: Multiplies the light's intensity (a lighting change: 0.5 dimmer, 1.5 brighter).
    light_scale: float = 1.0
    #: The rendered camera stands this far off its nominal pose: metres, degrees.
    pose_error: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 4096 and 16 <= self.height <= 4096):
            raise ConfigError("camera.size", "width and height must be in [16, 4096]")
        if not 10 <= self.fovy_degrees <= 120:
            raise ConfigError("camera.fovy_degrees", "must be in [10, 120]")
        if not 0 < self.hz <= 30:
            raise ConfigError("camera-hz", "must be in (0, 30]")
        if not 1 <= self.jpeg_quality <= 100:
            raise ConfigError("camera.jpeg_quality", "must be in [1, 100]")
        if not (0 <= self.noise_sigma <= 50 and 0 <= self.blur_pixels <= 31):
            raise ConfigError("camera.noise", "sigma in [0, 50] grey levels, blur in [0, 31] px")
        if not 0.1 <= self.light_scale <= 3:
            raise ConfigError("camera-light", "must be in [0.1, 3] times the default light")
        if not (0 <= self.pose_error[0] <= 0.05 and 0 <= self.pose_error[1] <= 5):
            raise ConfigError("camera-pose-error", "at most 0.05 m and 5 degrees")
        if np.linalg.norm(np.subtract(self.eye, self.target)) < 0.05:
            raise ConfigError("camera.eye", "must be at least 5 cm from the target")


class TripodCamera:
    """A fixed camera in a rendering SAPIEN scene."""

    def __init__(self, config: CameraConfig, scene: sapien.Scene) -> None:
        self.config = config
        self.scene = scene
        with default_shaders():
            self.camera = scene.add_camera(
                config.name,
                config.width * config.supersample,
                config.height * config.supersample,
                float(np.deg2rad(config.fovy_degrees)),
                0.01,
                10.0,
            )
        self._rng = np.random.default_rng(config.seed)
        self.camera.entity.set_pose(_off_by(config, self._rng))
        self.sequence = 0
        #: The depth frame rendered with the last ``capture`` (with ``config.depth``).
        self.last_depth: DepthImage | None = None

    def camera_matrix(self) -> np.ndarray:
        """K of the published image in OpenCV's convention (pixel i's centre at i; SAPIEN's
        projection puts it at i + 0.5)."""
        k = np.asarray(self.camera.get_intrinsic_matrix(), dtype=float)
        k[:2] /= self.config.supersample
        k[0, 2] -= 0.5
        k[1, 2] -= 0.5
        return k

    def base_T_camera(self) -> np.ndarray:
        """The camera's optical frame (OpenCV: x right, y down, z forward) in the robot base
        frame, 4 x 4."""
        extrinsic = np.eye(4)
        extrinsic[:3] = np.asarray(self.camera.get_extrinsic_matrix(), dtype=float)
        return np.linalg.inv(extrinsic)

    def render(self) -> np.ndarray:
        """The current view as an RGB uint8 image, with the configured noise and blur."""
        self.scene.update_render()
        self.camera.take_picture()
        return self._colour()

    def render_depth(self) -> np.ndarray:
        """Depth (metres along the optical axis, 0: none) of the last picture taken, through
        the configured sensor model (exact without one)."""
        position = self.camera.get_picture("Position")
        fine = np.where(position[..., 3] < 1.0, -position[..., 2], 0.0).astype(np.float64)
        noise = self.config.depth or DepthNoise.none()
        return sensor_depth(fine, self.config.supersample, noise, self._rng)

    def _colour(self) -> np.ndarray:
        rgb = picture_rgb(self.camera)
        if self.config.supersample > 1:
            size = (self.config.width, self.config.height)
            rgb = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
        return degrade(rgb, self.config, self._rng)

    def capture(self, stamp: float) -> CompressedImage:
        rgb = self.render()
        message = encode_image(rgb, self.config, stamp, self.sequence)
        if self.config.depth is not None:
            self.last_depth = DepthImage(
                camera=self.config.name,
                stamp=stamp,
                sequence=self.sequence,
                data=encode_depth_png(self.render_depth()),
            )
        self.sequence += 1
        return message

    def info(self, stamp: float) -> CameraInfo:
        return CameraInfo(
            camera=self.config.name,
            stamp=stamp,
            width=self.config.width,
            height=self.config.height,
            camera_matrix=[float(v) for v in self.camera_matrix().ravel()],
        )


def degrade(rgb: np.ndarray, config: CameraConfig, rng: np.random.Generator) -> np.ndarray:
    """Horizontal motion blur then Gaussian noise, as configured (none by default)."""
    if config.blur_pixels > 1:
        kernel = np.zeros((config.blur_pixels, config.blur_pixels), np.float32)
        kernel[config.blur_pixels // 2, :] = 1.0 / config.blur_pixels
        rgb = cv2.filter2D(rgb, -1, kernel)
    if config.noise_sigma > 0:
        noisy = rgb.astype(np.float32) + rng.normal(0, config.noise_sigma, rgb.shape)
        rgb = np.clip(noisy, 0, 255).astype(np.uint8)
    return rgb


def encode_image(
    rgb: np.ndarray, config: CameraConfig, stamp: float, sequence: int
) -> CompressedImage:
    bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    if config.format is ImageFormat.JPEG:
        ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, config.jpeg_quality])
    else:
        ok, data = cv2.imencode(".png", bgr)
    if not ok:
        raise ConfigError("camera.format", f"OpenCV cannot encode {config.format}")
    return CompressedImage(
        camera=config.name,
        stamp=stamp,
        sequence=sequence,
        format=config.format,
        data=data.tobytes(),
    )


def ideal_calibration(config: CameraConfig) -> tuple[np.ndarray, np.ndarray]:
    """The rendered camera's exact K (OpenCV convention) and optical frame in the robot base
    frame, computed from its configuration without rendering."""
    fy = config.height / 2 / np.tan(np.deg2rad(config.fovy_degrees) / 2)
    k = np.array([[fy, 0, config.width / 2 - 0.5], [0, fy, config.height / 2 - 0.5], [0, 0, 1]])
    pose = look_at(np.array(config.eye, dtype=float), np.array(config.target, dtype=float))
    forward, left, up = pose.to_transformation_matrix()[:3, :3].T
    base_T_camera = np.eye(4)
    base_T_camera[:3, :3] = np.stack([-left, -up, forward], axis=1)
    base_T_camera[:3, 3] = config.eye
    return k, base_T_camera


def out_of_view(
    k: np.ndarray, base_T_camera: np.ndarray, size: tuple[int, int], corners: np.ndarray
) -> bool:
    """Whether any of ``corners`` (:math:`(M, 3)`, robot base frame) is off the image of a
    camera (``k``, its pose ``base_T_camera``, ``size`` = (width, height) pixels) or behind it:
    a body partly out of the picture cannot be found by its segment."""
    camera_T_base = np.linalg.inv(base_T_camera)
    points = corners @ camera_T_base[:3, :3].T + camera_T_base[:3, 3]
    if np.any(points[:, 2] <= 0):
        return True
    u = k[0, 0] * points[:, 0] / points[:, 2] + k[0, 2]
    v = k[1, 1] * points[:, 1] / points[:, 2] + k[1, 2]
    width, height = size
    inside = (u >= 0) & (u <= width - 1) & (v >= 0) & (v <= height - 1)
    return not bool(np.all(inside))


def top_corners(position: np.ndarray, size: np.ndarray) -> np.ndarray:
    """The four corners of a box's top face, :math:`(4, 3)`."""
    half = np.asarray(size, dtype=float) / 2
    signs = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]], dtype=float)
    corners = np.empty((4, 3))
    corners[:, :2] = np.asarray(position, dtype=float)[:2] + signs * half[:2]
    corners[:, 2] = float(position[2]) + half[2]
    return corners


def light(scene: sapien.Scene, scale: float = 1.0) -> None:
    """Even light from above (the video recorder's), ``scale`` times as bright."""
    scene.set_ambient_light([0.45 * scale] * 3)
    scene.add_directional_light([0.3, 0.5, -1.0], [0.8 * scale] * 3)


def _off_by(config: CameraConfig, rng: np.random.Generator) -> sapien.Pose:
    """The camera's pose: the nominal one, moved by ``pose_error[0]`` metres and turned by
    ``pose_error[1]`` degrees, each in a direction drawn from ``rng``."""
    pose = look_at(np.array(config.eye, dtype=float), np.array(config.target, dtype=float))
    offset, degrees = config.pose_error
    if offset == 0 and degrees == 0:
        return pose
    shift, axis = rng.normal(size=3), rng.normal(size=3)
    shift *= offset / np.linalg.norm(shift)
    axis /= np.linalg.norm(axis)
    half = np.deg2rad(degrees) / 2
    turn = rotation_matrix(np.array([*(axis * np.sin(half)), np.cos(half)]))
    matrix = pose.to_transformation_matrix()
    matrix[:3, :3] = turn @ matrix[:3, :3]
    matrix[:3, 3] += shift
    return sapien.Pose(matrix)


# --- printed markers --------------------------------------------------------------------------
def marker_shapes(
    markers: MarkerMap, object_id: str, object_size: np.ndarray
) -> list[sapien.render.RenderShapeTriangleMesh]:
    """One textured square per marker of ``object_id``, lying 0.2 mm above its face, with a
    white quiet zone of one cell round the marker where the face has room."""
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, markers.dictionary))
    return [_marker_quad(dictionary, spec, object_size) for spec in markers.for_object(object_id)]


def _marker_quad(
    dictionary: cv2.aruco.Dictionary, spec: MarkerSpec, object_size: np.ndarray
) -> sapien.render.RenderShapeTriangleMesh:
    pose = marker_in_object(spec, object_size)
    right, up, normal = pose[:3, 0], pose[:3, 1], pose[:3, 2]
    centre = pose[:3, 3] + normal * 2e-4
    face_extent = min(
        float(np.abs(right) @ object_size), float(np.abs(up) @ object_size), spec.size * 8 / 6
    )
    side = max(face_extent, spec.size)
    marker_pixels = 6 * _CELL_PIXELS
    texture_pixels = round(marker_pixels * side / spec.size)
    image = np.full((texture_pixels, texture_pixels), 255, np.uint8)
    start = (texture_pixels - marker_pixels) // 2
    image[start : start + marker_pixels, start : start + marker_pixels] = (
        cv2.aruco.generateImageMarker(dictionary, spec.id, marker_pixels)
    )
    rgba = np.dstack([image, image, image, np.full_like(image, 255)])
    texture = sapien.render.RenderTexture2D(rgba, "R8G8B8A8Unorm", 1, "linear")
    h = side / 2
    corners = [
        centre - right * h - up * h,
        centre + right * h - up * h,
        centre + right * h + up * h,
        centre - right * h + up * h,
    ]
    vertices = np.array(corners, dtype=np.float32)
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)
    normals = np.tile(normal, (4, 1)).astype(np.float32)
    material = sapien.render.RenderMaterial(base_color=[1.0, 1.0, 1.0, 1.0], roughness=0.9)
    material.base_color_texture = texture
    return sapien.render.RenderShapeTriangleMesh(vertices, triangles, normals, uvs, material)
