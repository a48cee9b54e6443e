"""The ``world`` component: the simulated room with a PR2 and a KEMAR, on MuJoCo, with cameras and a laser.

It plays MORSE's part in the seed (chapter 7): it owns the scene, steps its physics on the runtime
clock, publishes the robots' sensors on out ports named after MORSE's ROS topics, and takes commands
on in ports, which ``pr2`` and ``morse_kemar`` connect to their own ports when they are loaded.
"""

from __future__ import annotations

import asyncio
import logging
import math
import re
from collections.abc import Callable
from typing import Any


from ..core import (
    Component, GenomException, InPort, InPortRuntime, LoadError, OutPort, OutPortRuntime, OverBudget,
    Reservation, String, Task,
)
from ._mjcf import KEMAR_CAMERAS, KEMAR_ORIGIN, PR2_CAMERAS, scene_xml
from ._render import LASER, RenderError, SensorRenderer
from ._render_supervisor import RenderSupervisor
from ._sim import PR2_JOINTS, Simulation
from ._types import (
    ARM_JOINTS, Header, HeadCommand, Image, JointState, LaserScan, LeftArmCommand, Odometry, Point, Pose,
    PoseStamped, PositionCommand, Quaternion, RightArmCommand, Timestamp, TorsoCommand, Twist,
)

__all__ = ["World", "parse_size", "render_memory", "SENSOR_DOWN"]

log = logging.getLogger(__name__)

#: The camera out ports and the model cameras they show.
CAMERA_PORTS = {"pr2_video": PR2_CAMERAS[0], "kemar_camera_left": KEMAR_CAMERAS[0],
                "kemar_camera_right": KEMAR_CAMERAS[1]}


_SIZE = re.compile(r"([0-9]{1,4})x([0-9]{1,4})", re.ASCII | re.IGNORECASE)
_RATE = re.compile(r"[0-9]{1,3}(\.[0-9]{1,6})?", re.ASCII)


def parse_size(text: str) -> tuple[int, int]:
    """``"256x256"`` as (width, height).

    Raises:
        LoadError: for anything but two integers from 8 to 2048 joined by ``x`` (ASCII digits only:
            ``²x8`` is no size).
    """
    match = _SIZE.fullmatch(text)
    if match is None or not (8 <= int(match.group(1)) <= 2048 and 8 <= int(match.group(2)) <= 2048):
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise LoadError(f"bad camera size {shown!r}: use WIDTHxHEIGHT, each 8 to 2048, such as 256x256")
    return int(match.group(1)), int(match.group(2))


def parse_rate(text: str) -> float:
    """``"10"`` or ``"2.5"`` as frames per second, from 0.1 to 50.

    Raises:
        LoadError: for anything else (ASCII digits only, no exponent, no NaN).
    """
    rate = float(text) if _RATE.fullmatch(text) else math.nan
    if not 0.1 <= rate <= 50:  # NaN fails this too
        shown = text if len(text) <= 40 else text[:37] + "..."
        raise LoadError(f"bad camera rate {shown!r}: 0.1 to 50 frames per second")
    return rate


#: What a render process takes before its cameras' frames (MuJoCo, OSMesa, the scene), measured.
RENDER_BASE_BYTES = 192 * 2**20
#: What each camera pixel adds (OpenGL buffers, the frames shared with the world), measured.
RENDER_BYTES_PER_PIXEL = 128


def render_memory(width: int, height: int) -> int:
    """About how much memory the render process of a world with cameras of *width* x *height* takes.

    Measured (``bench/budgets.py``): 180 MB at 256x256, 290 MB at 1024x1024, 690 MB at 2048x2048.
    """
    return RENDER_BASE_BYTES + RENDER_BYTES_PER_PIXEL * width * height


class SENSOR_DOWN(GenomException):
    """The cameras and laser have no current data: their render process died and is being restarted."""

    scope = "world"
    what: String


def _option(argv: list[str], flag: str, default: str) -> str:
    return argv[argv.index(flag) + 1] if flag in argv else default


class World(Component, name="world", version="1.0"):
    """The virtual room of the seed's chapter 7 on MuJoCo: a PR2, a KEMAR, coloured objects, sound-source markers.

    Physics steps on the runtime clock; cameras render off the event loop at ``-rate`` frames per second
    (``rgba8`` images of ``-size`` pixels).  Loading ``pr2`` or ``morse_kemar`` wires their ports here.
    """

    usage_options = [*Component.usage_options,
                     ("-size WIDTHxHEIGHT", "camera image size in pixels (default 256x256, the seed's)"),
                     ("-rate HZ", "camera and laser rate in frames per runtime second (default 10, at most 50)")]

    sim: Simulation | None = None
    renderer: SensorRenderer | None = None
    #: The render process, kept alive (its ``state()``: up, starts, failures, last error).
    rendering: RenderSupervisor | None = None
    _running = False
    _render_memory: Reservation | None = None

    physics = Task(period=0.02, doc="Steps the physics to the runtime clock, applies commands, publishes poses")
    sensors = Task(period=0.02, doc="Renders the cameras and sweeps the laser off the event loop, at -rate")

    pr2_odom = OutPort(Odometry, doc="PR2 base: x, y (m), heading w (rad) in the room, and their speeds")
    pr2_joints = OutPort(JointState, doc="PR2 torso (m), head and arm joints (rad): positions and speeds")
    pr2_video = OutPort(Image, doc="PR2 head camera (wide_stereo_l), rgba8")
    pr2_scan = OutPort(LaserScan, doc="PR2 base laser: 270° in 1° steps, 0.023 to 30 m")
    kemar_pose = OutPort(PoseStamped, doc="KEMAR head pose in the room (yaw about z, positive = left)")
    kemar_camera_left = OutPort(Image, doc="KEMAR left eye camera, rgba8")
    kemar_camera_right = OutPort(Image, doc="KEMAR right eye camera, rgba8")

    pr2_cmd_vel = InPort(Twist, doc="PR2 base velocity in its frame (m/s, rad/s); replaces a goal (MORSE 'cmd_vel')")
    pr2_goal = InPort(PositionCommand, doc="PR2 base goal pose; connected to pr2/Port_gotoposition")
    pr2_head = InPort(HeadCommand, doc="PR2 head goal; connected to pr2/Port_head")
    pr2_torso = InPort(TorsoCommand, doc="PR2 torso goal; connected to pr2/Port_torso")
    pr2_l_arm = InPort(LeftArmCommand, doc="PR2 left arm goal; connected to pr2/Port_l_arm")
    pr2_r_arm = InPort(RightArmCommand, doc="PR2 right arm goal; connected to pr2/Port_r_arm")
    kemar_motion = InPort(Twist, doc="KEMAR neck speed (angular.z, rad/s); connected to morse_kemar/RobotMotion")

    async def on_start(self) -> None:
        """Build the scene and the renderer; a failed start ends the tasks it began with."""
        try:
            await self._start()
        except BaseException:
            await self.stop()  # the tasks started before on_start: they end with the failed load
            raise

    async def _start(self) -> None:
        self.camera_size = parse_size(_option(self.argv, "-size", "256x256"))
        self.frame_period = 1.0 / parse_rate(_option(self.argv, "-rate", "10"))
        width, height = self.camera_size
        memory, what = render_memory(width, height), f"a world of {width}x{height} cameras"
        try:
            self.host.settings.budgets.check("world_bytes", what, memory)
        except OverBudget as exc:
            raise LoadError(f"{exc}: choose a smaller -size") from None
        # Every world together (429 at the gateway: try again once another world is unloaded).
        self._render_memory = self.host.ledgers.render.reserve(memory, self.instance, what)
        xml = scene_xml(width, height)

        def make(on_spawn: Callable[[int], None]) -> SensorRenderer:
            return SensorRenderer(xml, width, height, tuple(CAMERA_PORTS.values()), "base_laser", on_spawn)

        self.rendering = RenderSupervisor(make, self.instance, self._sensors_down)
        self.renderer = self.rendering.renderer
        # Importing MuJoCo and compiling the scene take about half a second, here off the event loop
        # (a thread) and in the render process at the same time.  The tasks already run meanwhile;
        # they wait for ``_running``.
        # On a simulated clock that moves when the rig is idle, time waits for the world to exist.
        with self.clock.holding():
            sim, opened = await asyncio.gather(asyncio.to_thread(Simulation, width, height), self.rendering.open(),
                                               return_exceptions=True)  # both end before the load does
        if isinstance(opened, RenderError):
            raise LoadError(f"the world cannot render its cameras ({opened}); MuJoCo renders offscreen "
                            "with MUJOCO_GL=osmesa and Debian's libosmesa6") from opened
        if isinstance(sim, Exception):  # MuJoCo missing or refusing its settings (MUJOCO_GL...)
            raise LoadError(f"the world cannot start MuJoCo ({type(sim).__name__}: {sim})") from sim
        if isinstance(opened, BaseException):
            raise opened
        if isinstance(sim, BaseException):
            raise sim
        self.sim = sim
        self._origin = self.clock.now()
        self._next_frame = 0.0
        self._seq = 0
        self._seen: dict[str, tuple[int, int]] = {}
        self._publish_state()
        self._running = True  # the tasks step and render from here on: everything they use is set above

    async def on_stop(self) -> None:
        self._running = False
        try:
            if self.rendering is not None:
                await self.rendering.aclose()
        finally:
            if self._render_memory is not None:
                self._render_memory.release()

    # -- commands --------------------------------------------------------------------------

    def _new_command(self, port: InPortRuntime) -> Any:
        """The data of *port*'s out port if it was published since last asked (None otherwise)."""
        remote = port.remote
        if remote is None or remote.version == 0:
            return None
        key = (id(remote), remote.version)
        if self._seen.get(port.name) == key:
            return None
        self._seen[port.name] = key
        return port.read()

    def _apply_commands(self) -> None:
        sim = self.sim
        assert sim is not None  # the tasks run from on_start's end
        if (twist := self._new_command(self.pr2_cmd_vel)) is not None:
            sim.drive(twist.linear.x, twist.linear.y, twist.angular.z)
        if (goal := self._new_command(self.pr2_goal)) is not None:
            sim.drive_to(goal.x, goal.y, goal.w)
        if (head := self._new_command(self.pr2_head)) is not None:
            sim.move_joints({"head_pan_joint": head.pan, "head_tilt_joint": head.tilt}, head.time_to_finish)
        if (torso := self._new_command(self.pr2_torso)) is not None:
            sim.move_joints({"torso_lift_joint": torso.torso}, torso.time_to_finish)
        for port, side in ((self.pr2_l_arm, "l"), (self.pr2_r_arm, "r")):
            if (arm := self._new_command(port)) is not None:
                goals = {f"{side}_{j}": getattr(arm, f"{side}_{j}") for j in ARM_JOINTS}
                sim.move_joints(goals, arm.time_to_finish)
        if (motion := self._new_command(self.kemar_motion)) is not None:
            sim.kemar_speed = motion.angular.z

    # -- the physics task --------------------------------------------------------------------

    @physics.periodic
    def _step(self) -> None:
        if not self._running:  # still starting, or stopping
            return
        # Catch up with the clock first: a command then starts at the time it arrived, not at the
        # time of a simulation that lagged (a motion would end early on the clock).
        assert self.sim is not None  # set before the renderer
        self.sim.advance(self.clock.now() - self._origin)
        self._apply_commands()
        self._publish_state()

    def _header(self, frame: str) -> Header:
        self._seq += 1
        return Header(seq=self._seq, stamp=Timestamp.from_seconds(self.clock.wall()), frame_id=frame)

    def _publish_state(self) -> None:
        sim = self.sim
        assert sim is not None  # called from on_start once it is set, then by the physics task
        x, y, w = sim.base_pose()
        vx, vy, vw = sim.base_speed()
        self.pr2_odom.publish(Odometry(x, y, w, vx, vy, vw, Timestamp.from_seconds(self.clock.wall())))
        self.pr2_joints.publish(JointState(self._header("base_footprint"), list(PR2_JOINTS),
                                           sim.joint_positions(PR2_JOINTS), sim.joint_speeds(PR2_JOINTS)))
        yaw = sim.kemar_yaw()
        pose = Pose(Point(KEMAR_ORIGIN[0], KEMAR_ORIGIN[1], 1.47),
                    Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))
        self.kemar_pose.publish(PoseStamped(self._header("map"), pose))

    # -- the sensors task --------------------------------------------------------------------

    @sensors.periodic
    async def _sense(self) -> None:
        if not self._running:  # still starting, or stopping
            return
        now = self.clock.now() - self._origin
        if now < self._next_frame:
            return
        # Best effort, as MORSE: a frame that took longer than a period delays the next one.
        self._next_frame = max(self._next_frame + self.frame_period, now)
        assert self.sim is not None and self.rendering is not None  # set before _running
        try:
            # A frame shows its instant: on a simulated clock that moves when the rig is idle, time
            # waits for the render process (real time on a rig, where holding changes nothing).
            with self.clock.holding():
                frames, ranges = await self.rendering.render(self.sim.snapshot())
        except RenderError:
            # Reads of the cameras and laser are refused meanwhile (_sensors_down); simulated time
            # runs on: a process that cannot start must not stop the physics.
            await self.rendering.restart()
            return
        width, height = self.camera_size
        for port, camera in CAMERA_PORTS.items():
            # The frame is published as drawn, in memory shared with the render process, read-only.
            self.out_port(port).publish(Image(width, height, "rgba8", width * 4, frames[camera]))
        assert ranges is not None
        self.pr2_scan.publish(LaserScan(self._header("base_laser_link"), LASER["angle_min"], LASER["angle_max"],
                                        LASER["angle_increment"], LASER["range_min"], LASER["range_max"], ranges))

    def _sensors_down(self, reason: str) -> None:
        """The render process failed: camera and laser reads are refused until its replacement's first frame."""
        down = SENSOR_DOWN(what=f"{reason}; a new render process is starting")
        for port in (*CAMERA_PORTS, "pr2_scan"):
            self.out_port(port).withdraw(down)

    # -- wiring for the robot components -------------------------------------------------------

    def wire(self, robot: Component, pairs: dict[str, str]) -> None:
        """Connect ports between *robot* and this world: ``{robot_port: world_port}``.

        An in port of either side is connected to the out port of the other.
        """
        for robot_port, world_port in pairs.items():
            mine, theirs = self.port(world_port), robot.port(robot_port)
            if isinstance(mine, InPortRuntime) and isinstance(theirs, OutPortRuntime):
                mine.connect(theirs, f"{robot.instance}/{robot_port}")
            elif isinstance(theirs, InPortRuntime) and isinstance(mine, OutPortRuntime):
                theirs.connect(mine, f"{self.instance}/{world_port}")
            else:
                raise TypeError(f"{robot.instance}/{robot_port} and {self.instance}/{world_port} "
                                "are not an in port and an out port")


