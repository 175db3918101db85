"""deltacal's correction of a Delta printer (linear or rotary) applied by Klipper to every move (an extra).

Written by deltacal (``deltacal export CAL.toml --controller klipper --config printer.cfg --live
-o OUTDIR``), with ``deltacal_geometry.cfg``, the ``[deltacal_geometry]`` section of the data. To
install: copy this file into ``klippy/extras/``, add ``[include deltacal_geometry.cfg]`` to
``printer.cfg``, restart Klipper. ``DELTACAL_GEOMETRY`` reports its state, ``DELTACAL_GEOMETRY
ENABLE=0`` turns it off (``ENABLE=1`` on again). Standard-library Python only: it runs in Klipper's
own Python on the printer's host. It is deltacal's (BSD-3-Clause), written for Klipper's interfaces;
it holds no code of Klipper's.

What it does, move by move: a move's program point x is sent to Klipper's kinematics as
``x + w(x) c(x)``, the correction interpolated (Catmull-Rom, tricubic) from its values at the
nodes of a regular grid (deltacal computed them exactly: the command that puts the identified
printer's nozzle on x through Klipper's own model), times its weight where the calibration holds
(from the correction's sigma, interpolated trilinearly from the calibration's sigma grid, as
deltacal's offline route weights it; a calibration without one, a geometry file: 1). A long move
is cut into segments short enough that the nozzle stays on the straight line. A move Klipper's
limits refuse (its program point, as Klipper's kinematics check it; or a corrected point of it) is
refused whole, before any segment is made, in Klipper's words for the program point. Beyond the
printer's reach the correction is 0. Klipper's position reports (``get_position``) are the
program's coordinates: the command is inverted by fixed-point iteration (a position outside the
grid, made up while homing, is returned as it is); it never raises.

Where it sits: a move transform (``gcode_move.set_move_transform``) registered while the
configuration is read, over ``bed_mesh`` (or ``bed_tilt``), which it loads first when the
configuration has it; ``skew_correction`` and ``z_thermal_adjust`` (registered at connect) and
``exclude_object`` (at run time) go over it. At connect it reads Klipper's values from the
kinematics (``delta`` or ``rotary_delta``: the section's ``kinematics``) and refuses to start if they
are not those the correction was computed for. A program already corrected by deltacal (its first
line is the marker ``; corrected by deltacal ...``) is refused when the marker line reaches
Klipper's G-code dispatcher (a comment line: its default handler, which this module wraps).
"""

import base64
import logging
import math
import sys
import zlib
from array import array
from bisect import bisect_right
from itertools import repeat
from operator import add, mul

#: The format of the ``[deltacal_geometry]`` section this module reads.
FORMAT = "deltacal-klipper-live-2"
#: How the first line of a program corrected offline by deltacal starts (deltacal.gcode.marker).
MARKER = "; corrected by deltacal "
#: The towers, in Klipper's order.
TOWERS = "abc"
#: Relative difference of a value of Klipper's from the section's that is still the same value.
SAME_VALUE = 1e-9
#: The inverse's fixed-point iterations at most, and the change at which it stops [mm].
INVERSE_ITERATIONS = 50
INVERSE_TOLERANCE = 1e-10
#: A correction this many times its sigma is wholly applied (deltacal.holds.SIGNIFICANT).
SIGNIFICANT = 2.0
#: A move of the nozzle shorter than this is Klipper's extrusion alone, which its limits do not check [mm]
#: (klippy/toolhead.py's Move).
KLIPPER_LEAST_MOVE = 1e-9
#: The segments a move is cut into at most (a move within Klipper's limits needs a few hundred at most).
MOST_SEGMENTS = 10000


def correction_weight(sigma, bound):
    """How much of a correction of sigma ``sigma`` is applied (deltacal.holds.correction_weight).

    1 up to half the bound, 0 from it, the smooth step ``1 - 3t^2 + 2t^3`` between; a NaN sigma: 0.
    """
    if sigma != sigma:  # NaN
        return 0.0
    t = min(max((sigma - 0.5 * bound) / (0.5 * bound), 0.0), 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def significance_weight(size, sigma):
    """How much of a correction of this size and sigma is applied (deltacal.holds.significance_weight).

    0 up to its sigma; then the applied size is sigma f(u), u = size / sigma, f = (u - 1)^2 / (2 (S - 1))
    up to S = SIGNIFICANT, u - (1 + S) / 2 beyond: the weight f(u) / u.
    """
    u = size / max(sigma, 1e-12)
    if not u > 1.0:
        return 0.0
    width = SIGNIFICANT - 1.0
    eased = (u - 1.0) ** 2 / (2.0 * width) if u < SIGNIFICANT else u - 1.0 - 0.5 * width
    return eased / u


def _cell(nodes, value):
    """The cell of ``value`` among increasing nodes (its lower node's index) and the fraction across it.

    Held at the edges (deltacal.holds's ``_cell``).
    """
    last = len(nodes) - 1
    held = min(max(value, nodes[0]), nodes[last])
    index = min(max(bisect_right(nodes, held) - 1, 0), last - 1)
    fraction = (held - nodes[index]) / (nodes[index + 1] - nodes[index])
    return index, min(max(fraction, 0.0), 1.0)


class SigmaGrid:
    """The sigma of the correction on the calibration's cylindrical grid, and the weights it gives.

    deltacal.holds.WhereItHolds's interpolation (trilinear in radius, azimuth and height, held at the
    grid's edges) and weights. ``radius`` (increasing from 0), ``azimuth`` (evenly over a turn [rad]),
    ``height``: the nodes; ``sigma``: the horizontal part's at each node (radius slowest, height
    fastest), then the vertical's; ``bound``: the sigma of a correction accepted (inf: all) [mm];
    ``significance``: the horizontal part weighted by its significance too (a calibration at one height).
    """

    def __init__(self, radius, azimuth, height, sigma, bound, significance=True):
        self.radius, self.azimuth, self.height = list(radius), list(azimuth), list(height)
        self.sigma_values, self.bound, self.significance = sigma, bound, significance
        self.step = 2.0 * math.pi / len(self.azimuth)
        self.stride_a = len(self.height)
        self.stride_r = len(self.azimuth) * len(self.height)
        self.vertical_start = len(self.radius) * self.stride_r
        self._corners = {}
        self._heights = {}

    def sigma(self, x, y, z):
        """The sigma of the correction's horizontal and vertical parts at (x, y, z) [mm] (cells kept)."""
        ir, fr = _cell(self.radius, math.hypot(x, y))
        count, step = len(self.azimuth), self.step
        phi = math.atan2(y, x) % (2.0 * math.pi)
        ia = int(math.floor((phi - self.azimuth[0]) / step)) % count
        fa = min(max(((phi - self.azimuth[ia]) / step) % 1.0, 0.0), 1.0)
        at_height = self._heights.get((ir, ia, z))
        if at_height is None:
            at_height = self._at_height(ir, ia, z)
        h00, h01, h10, h11, v00, v01, v10, v11 = at_height
        gr, ga = 1.0 - fr, 1.0 - fa
        return (gr * (ga * h00 + fa * h01) + fr * (ga * h10 + fa * h11),
                gr * (ga * v00 + fa * v01) + fr * (ga * v10 + fa * v11))

    def _at_height(self, ir, ia, z):
        """The sigma of the 4 node columns of cell (ir, ia) at height z, horizontal then vertical (kept)."""
        iz, fz = _cell(self.height, z)
        corners = self._corners.get((ir, ia, iz))
        if corners is None:
            corners = self._gather(ir, ia, iz)
        at_height = tuple((1.0 - fz) * low + fz * high
                          for low, high in zip(corners[::2], corners[1::2]))  # noqa: B905 (Python 3.7+)
        if len(self._heights) >= 4096:
            self._heights.clear()
        self._heights[(ir, ia, z)] = at_height
        return at_height

    def _gather(self, ir, ia, iz):
        """The sigma at the 8 nodes of cell (ir, ia, iz), horizontal then vertical (kept)."""
        values, sr, sa, count = self.sigma_values, self.stride_r, self.stride_a, len(self.azimuth)
        corners = []
        for start in (0, self.vertical_start):
            for dr in (0, 1):
                for da in (0, 1):
                    base = start + (ir + dr) * sr + ((ia + da) % count) * sa + iz
                    corners += [values[base], values[base + 1]]
        if len(self._corners) >= 4096:
            self._corners.clear()
        self._corners[(ir, ia, iz)] = corners
        return corners

    def weights(self, x, y, z, cx, cy):
        """The weights of the correction (cx, cy, ...) at (x, y, z): its horizontal part's, its vertical's."""
        if not math.isfinite(self.bound):
            return 1.0, 1.0
        horizontal, vertical = self.sigma(x, y, z)
        along = significance_weight(math.hypot(cx, cy), horizontal) if self.significance else 1.0
        return correction_weight(horizontal, self.bound) * along, correction_weight(vertical, self.bound)


def catmull_rom(t):
    """The 4 weights of Catmull-Rom's cubic convolution at a fraction t in [0, 1)."""
    t2 = t * t
    t3 = t2 * t
    return (0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2) + 1.0,
            0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2))


class CorrectionGrid:
    """The correction at the nodes of a regular grid, and its interpolation [mm].

    ``origin`` the first node, ``step`` the spacing, ``shape`` nodes along x, y, z; ``values`` the 3
    components at each node (x slowest, the component fastest) in units of ``scale``; ``curvature``:
    the bound of the second derivative [1/mm] per ring k x step (non-decreasing) and z node,
    ``cells`` per cell of the grid (i slowest; None: ``curvature`` alone), to split moves; ``holds``:
    the :class:`SigmaGrid`, or None: the correction applied wholly.
    """

    def __init__(self, origin, step, shape, values, curvature, scale=1.0, holds=None, cells=None):
        self.x0, self.y0, self.z0 = origin
        self.step = step
        self.inverse_step = 1.0 / step
        self.nx, self.ny, self.nz = shape
        self.values = values
        self.stride_z = 3
        self.stride_y = 3 * self.nz
        self.stride_x = 3 * self.nz * self.ny
        self.curvature = curvature
        self.scale = scale
        self.holds = holds
        self.cells = cells
        self._plane = None
        self._columns = ()
        self._cells = {}
        self._planes = {}
        self._free = {}

    def at(self, x, y, z):
        """The correction at (x, y, z), or None beyond the grid.

        The 64 nodes around the point's cell are contracted along z for its height and kept, so that a
        layer's next points in the cell cost 8 weights and 3 sums of 16 products.
        """
        u = (x - self.x0) * self.inverse_step
        v = (y - self.y0) * self.inverse_step
        w = (z - self.z0) * self.inverse_step
        if not (1.0 <= u < self.nx - 2 and 1.0 <= v < self.ny - 2 and 1.0 <= w < self.nz - 2):
            return None
        i, j = int(u), int(v)
        if (i, j, w) != self._plane:
            self._contract(i, j, w)
        a0, a1, a2, a3 = catmull_rom(u - i)
        b0, b1, b2, b3 = catmull_rom(v - j)
        scale, out = self.scale, []
        for p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12, p13, p14, p15 in self._columns:
            out.append(scale * (a0 * (b0 * p0 + b1 * p1 + b2 * p2 + b3 * p3)
                                + a1 * (b0 * p4 + b1 * p5 + b2 * p6 + b3 * p7)
                                + a2 * (b0 * p8 + b1 * p9 + b2 * p10 + b3 * p11)
                                + a3 * (b0 * p12 + b1 * p13 + b2 * p14 + b3 * p15)))
        return tuple(out)

    def _contract(self, i, j, w):
        """The 16 columns of 4 nodes around cell (i, j) at height w (in nodes), contracted along z (kept)."""
        self._plane = (i, j, w)
        columns = self._planes.get(self._plane)
        if columns is None:
            k = int(w)
            cell = self._cells.get((i, j, k))
            if cell is None:
                cell = self._gather(i, j, k)
            z0, z1, z2, z3 = (repeat(f) for f in catmull_rom(w - k))
            columns = tuple(list(map(add, map(add, map(mul, c0, z0), map(mul, c1, z1)),
                                     map(add, map(mul, c2, z2), map(mul, c3, z3))))
                            for c0, c1, c2, c3 in cell)
            if len(self._planes) >= 1024:  # a layer's cells, many times over (48 floats each)
                self._planes.clear()
            self._planes[self._plane] = columns
        self._columns = columns

    def _gather(self, i, j, k):
        """The 64 nodes around cell (i, j, k): per component, per z node, the 16 columns' values (kept)."""
        values, sx, sy = self.values, self.stride_x, self.stride_y
        columns = [(i - 1 + a) * sx + (j - 1 + b) * sy + (k - 1) * 3 for a in range(4) for b in range(4)]
        cell = tuple(tuple([values[n + 3 * c + component] for n in columns] for c in range(4))
                     for component in range(3))
        if len(self._cells) >= 4096:  # a print's cells, many times over
            self._cells.clear()
        self._cells[(i, j, k)] = cell
        return cell

    def correction(self, x, y, z):
        """The correction applied at (x, y, z): interpolated, each part weighted (None beyond the grid)."""
        c = self.at(x, y, z)
        if c is None or self.holds is None:
            return c
        horizontal, vertical = self.holds.weights(x, y, z, c[0], c[1])
        return horizontal * c[0], horizontal * c[1], vertical * c[2]

    def command(self, x, y, z):
        """The command for the program point (x, y, z): the point plus its correction."""
        c = self.correction(x, y, z)
        if c is None:
            return x, y, z
        return x + c[0], y + c[1], z + c[2]

    def program_point(self, x, y, z):
        """The program point whose command is (x, y, z) (fixed-point iteration), else it; never raises."""
        try:
            px, py, pz = x, y, z
            for _ in range(INVERSE_ITERATIONS):
                c = self.correction(px, py, pz)
                if c is None:
                    return x, y, z
                nx, ny, nz = x - c[0], y - c[1], z - c[2]
                change = abs(nx - px) + abs(ny - py) + abs(nz - pz)
                px, py, pz = nx, ny, nz
                if change <= INVERSE_TOLERANCE:
                    return px, py, pz
            logging.warning("deltacal_geometry: no program point found for the position %.6f %.6f %.6f;"
                            " kept as it is", x, y, z)
        except Exception:  # a report of Klipper's position must not fail: Klipper would shut down
            logging.exception("deltacal_geometry: position %r %r %r kept as it is", x, y, z)
        return x, y, z

    def segments(self, start, end, tolerance):
        """Segments to cut a move into so that the nozzle stays within ``tolerance`` of the line.

        A segment of length s leaves its chord by s^2 K / 8 at most, K the curvature bound of the
        move's larger radius and heights (or cells). At most :data:`MOST_SEGMENTS`; 1 for a length NaN.
        """
        dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not length < math.inf:  # a point that is not one: Klipper's to refuse, never a list of segments
            return 1
        free = self._free.get(tolerance)
        if free is None:  # the longest segment the largest bound allows: shorter moves are never cut
            largest = max(max(row) for row in self.curvature) if self.cells is None else max(self.cells)
            free = self._free[tolerance] = math.sqrt(8.0 * tolerance / largest) if largest > 0.0 else math.inf
        if length <= free:
            return 1
        bound = self._ring_bound(start, end) if self.cells is None else self._cell_bound(start, end)
        longest = math.sqrt(8.0 * tolerance / bound) if bound > 0.0 else length
        return min(max(1, int(math.ceil(length / longest))), MOST_SEGMENTS)

    def _ring_bound(self, start, end):
        """The curvature bound of a move from ``curvature``: its ring at the larger radius, its layers."""
        radius = max(math.hypot(start[0], start[1]), math.hypot(end[0], end[1]))
        row = self.curvature[min(int(radius * self.inverse_step) + 1, len(self.curvature) - 1)]
        last = len(row) - 1
        low = min(max(int((min(start[2], end[2]) - self.z0) * self.inverse_step), 0), last)
        high = min(max(int((max(start[2], end[2]) - self.z0) * self.inverse_step) + 1, 0), last)
        return max(row[low:high + 1])

    def _cell_bound(self, start, end):
        """A move's curvature bound from ``cells``: the largest of the cells its box crosses."""
        spans = []
        for axis, origin, count in ((0, self.x0, self.nx), (1, self.y0, self.ny), (2, self.z0, self.nz)):
            low = (min(start[axis], end[axis]) - origin) * self.inverse_step
            high = (max(start[axis], end[axis]) - origin) * self.inverse_step
            spans.append((min(max(int(math.floor(low)), 0), count - 2),
                          min(max(int(math.floor(high)), 0), count - 2)))
        (i0, i1), (j0, j1), (k0, k1) = spans
        cells, stride_j = self.cells, self.nz - 1
        stride_i = (self.ny - 1) * stride_j
        return max(max(cells[i * stride_i + j * stride_j + k0:i * stride_i + j * stride_j + k1 + 1])
                   for i in range(i0, i1 + 1) for j in range(j0, j1 + 1))


class DeltacalGeometry:
    """The ``[deltacal_geometry]`` section: Klipper's move transform that applies the correction."""

    def __init__(self, config):
        self.printer = printer = config.get_printer()
        self.name = config.get_name()
        self.grid, self.values, self.volume = read_section(config)
        self.kind, (self.keys, self.limits_kind) = kinematics_of(config)
        self.calibration = config.get("calibration")
        self.tolerance = read_float(config, "split_tolerance", above=0.0, default=0.01)
        self.error_text = config.get("sampling_error", "")
        self.enabled = True
        self.last_position = [0.0, 0.0, 0.0, 0.0]
        self.limits = None
        self.kinematics = None
        # bed_mesh and bed_tilt take the first place in the chain without force: loaded first, they
        # are under this transform (the correction first, then the bed's height map)
        for below in ("bed_mesh", "bed_tilt"):
            if config.has_section(below):
                printer.load_object(config, below)
        self.gcode_move = printer.load_object(config, "gcode_move")
        self.next_transform = self.gcode_move.set_move_transform(self, force=True)
        self.gcode = gcode = printer.lookup_object("gcode")
        self._default_handler = getattr(gcode, "cmd_default", None)
        if self._default_handler is None:
            raise config.error("deltacal_geometry: this Klipper's G-code dispatcher has no default handler: "
                               "a program corrected offline (its marker line) could not be refused")
        gcode.cmd_default = self._cmd_default
        gcode.register_command("DELTACAL_GEOMETRY", self.cmd_DELTACAL_GEOMETRY,
                               desc=self.cmd_DELTACAL_GEOMETRY_help)
        printer.register_event_handler("klippy:connect", self._handle_connect)

    def _handle_connect(self):
        """Klipper's delta values and limits, read from its kinematics, checked against the section's."""
        toolhead = self.printer.lookup_object("toolhead")
        if self.next_transform is None:  # nothing under it: the toolhead (made after the sections)
            self.next_transform = toolhead
        kinematics = toolhead.get_kinematics()
        calibration = getattr(kinematics, "get_calibration", lambda: None)()
        klipper = klipper_values(calibration, self.keys) if hasattr(kinematics, "get_status") else None
        if klipper is None:
            raise self.printer.config_error(f"deltacal_geometry: the printer's kinematics is not Klipper's "
                                            f"{self.kind}: the correction was computed for its values")
        status = kinematics.get_status(self.printer.get_reactor().monotonic())
        check_values(self.values, klipper, self.printer.config_error, self.keys)
        self.limits = self.limits_kind(calibration, status, getattr(kinematics, "home_position", None))
        check_volume(self.volume, self.limits, self.printer.config_error)
        self.kinematics = kinematics

    # The move transform (gcode_move's interface) ---------------------------------------------
    def get_position(self):
        """The program's coordinates of the position under this transform."""
        position = list(self.next_transform.get_position())
        if self.enabled:
            position[:3] = self.grid.program_point(position[0], position[1], position[2])
        self.last_position[:] = position
        return list(position)

    def move(self, newpos, speed):
        """Send a move, corrected and cut into segments so that the nozzle follows its straight line.

        Refused whole before any segment is made: its program point as Klipper refuses it, then its
        corrected points.
        """
        if not self.enabled:
            self.next_transform.move(newpos, speed)
            self.last_position[:] = newpos
            return
        start, limits = self.last_position, self.limits
        checked = limits is not None and limits.moves_nozzle(start, newpos)
        if checked:
            refusal = limits.refusal(newpos, self.kinematics.get_status(None).get("homed_axes") == "xyz")
            if refusal:
                raise self.gcode.error(refusal)
        count = self.grid.segments(start, newpos, self.tolerance)
        if count == 1:
            commands = [list(newpos)]
        else:
            commands = [[s + n / count * (e - s) for s, e in zip(start, newpos)]  # noqa: B905 (Python 3.7+)
                        for n in range(1, count)] + [list(newpos)]
        for command in commands:
            command[:3] = self.grid.command(command[0], command[1], command[2])
        if checked:
            self._check_limits(newpos, commands)
        for command in commands:
            self.next_transform.move(command, speed)
        self.last_position[:] = newpos

    def _check_limits(self, newpos, commands):
        """Refuse a move whose corrected points Klipper's limits refuse, as a whole, before any is sent."""
        for command in commands:
            broken = self.limits.outside(command[0], command[1], command[2])
            if broken:
                raise self.gcode.error(
                    f"deltacal_geometry: the program's point X{newpos[0]:.4f} Y{newpos[1]:.4f} "
                    f"Z{newpos[2]:.4f}, corrected, is X{command[0]:.4f} Y{command[1]:.4f} Z{command[2]:.4f}: "
                    f"{broken}; or turn the correction off: DELTACAL_GEOMETRY ENABLE=0")

    # Commands and status -----------------------------------------------------------------------
    def _cmd_default(self, gcmd):
        """Klipper's default G-code handler, which a comment line reaches: refuse deltacal's marker."""
        if self.enabled and gcmd.get_commandline().lstrip("\ufeff \t").startswith(MARKER):
            raise gcmd.error("deltacal_geometry: this program is already corrected by deltacal (its line "
                             f"'{gcmd.get_commandline().strip()[:80]}'): corrected again, every move would "
                             "be off by the correction; print the program as sliced, or turn the live "
                             "correction off first (DELTACAL_GEOMETRY ENABLE=0)")
        return self._default_handler(gcmd)

    cmd_DELTACAL_GEOMETRY_help = "Report deltacal's live correction, or turn it off or on (ENABLE=0|1)"

    def cmd_DELTACAL_GEOMETRY(self, gcmd):
        """``DELTACAL_GEOMETRY [ENABLE=0|1]``."""
        enable = gcmd.get_int("ENABLE", None, minval=0, maxval=1)
        if enable is not None and bool(enable) != self.enabled:
            self.enabled = bool(enable)
            self.gcode_move.reset_last_position()  # the program's coordinates, through the new state
        gcmd.respond_info(self.state_text())

    def state_text(self):
        """The state, in words."""
        if not self.enabled:
            return ("deltacal_geometry: off: moves go to Klipper's kinematics as the program gives them "
                    "(DELTACAL_GEOMETRY ENABLE=1 to correct them)")
        return (f"deltacal_geometry: on: every move corrected for the calibration {self.calibration} "
                f"(grid {self.grid.step:g} mm; {self.error_text}; long moves cut within "
                f"{self.tolerance:g} mm of their line); move transforms: {self.chain_text()}")

    def chain_text(self):
        """Klipper's move transforms in the order a move goes through them, this one's place among them."""
        names = []
        transform = getattr(self.gcode_move, "move_transform", None)
        while transform is not None and transform is not self and len(names) < 16:
            names.append(type(transform).__name__)
            transform = getattr(transform, "next_transform", None)
        names += ["deltacal_geometry", type(self.next_transform).__name__]
        return " > ".join(names)

    def get_status(self, eventtime=None):
        """The state for Klipper's status (``printer.deltacal_geometry``)."""
        return {"enabled": self.enabled, "calibration": self.calibration, "grid_step": self.grid.step}


class Limits:
    """Klipper's delta limits on a move's end (``check_move``), from its kinematics' live values.

    ``calibration``, ``status``: its ``get_calibration()``, ``get_status()``; ``home``: its home position (a
    move down from above the top there is let through), or None.
    """

    def __init__(self, calibration, status, home=None):
        self.max_xy = float(status["axis_maximum"][0])
        self.min_z = float(status["axis_minimum"][2])
        self.max_z = float(status["axis_maximum"][2])
        self.limit_z = float(status["cone_start_z"])
        self.radius = float(calibration.radius)
        self.arm = float(min(calibration.arms))
        self.home = None if home is None else tuple(float(v) for v in home[:3])

    @staticmethod
    def moves_nozzle(start, end):
        """Whether Klipper checks a move: its nozzle moves (Klipper's ``Move`` arithmetic), or NaN."""
        dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
        return not math.sqrt(dx * dx + dy * dy + dz * dz) < KLIPPER_LEAST_MOVE

    def refusal(self, end, homed):
        """Klipper's refusal of a move of the nozzle to ``end``, in its words, or "" (none).

        As ``check_move`` and ``move_error`` say it: "Must home first", "Move out of range" (not the
        move down from above the top at home), with the end's coordinates; an end that is not a
        number, or far above the top (Klipper raises there), is out of range.
        """
        x, y, z = end[0], end[1], end[2]
        if not homed:
            what = "Must home first"
        elif not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)) or self._refuses(x, y, z):
            what = "Move out of range"
        else:
            return ""
        extrusion = end[3] if len(end) > 3 else 0.0
        return f"{what}: {x:.3f} {y:.3f} {z:.3f} [{extrusion:.3f}]"

    def _refuses(self, x, y, z):
        """Whether Klipper's limits refuse the end (x, y, z) of a move (its ``check_move``'s arithmetic)."""
        limit_xy2 = self.max_xy * self.max_xy
        if z > self.limit_z:
            allowed = self.taper(z)
            limit_xy2 = min(limit_xy2, allowed * allowed)
        if x * x + y * y > limit_xy2 or z > self.max_z or z < self.min_z:
            home = self.home
            return home is None or (x, y) != home[:2] or z < self.min_z or z > home[2]
        return False

    def outside(self, x, y, z):
        """The limit (x, y, z) breaks, in words with the key that admits it, or "" (none)."""
        if z < self.min_z:
            return (f"below minimum_z_position {self.min_z:g}: set [printer] minimum_z_position: "
                    f"{math.floor(z * 100.0) / 100.0:.2f}")
        if z > self.max_z:
            return f"above {self.max_z:g}, the lowest position_endstop: lower the move"
        xy = math.hypot(x, y)
        if xy > self.max_xy:
            return f"radius {xy:.4f} beyond Klipper's {self.max_xy:.4f}: {self.admits_radius(xy)}"
        if z > self.limit_z and xy > self.taper(z):
            return (f"radius {xy:.4f} beyond Klipper's taper near the top ({self.taper(z):.4f} at this Z): "
                    "lower the move or bring it nearer the centre")
        return ""

    def taper(self, z):
        """The radius Klipper allows at a height z above ``limit_z`` (delta.py's arithmetic)."""
        above = z - self.limit_z
        return self.radius - math.sqrt(max(self.arm * self.arm - (self.arm - above) ** 2, 0.0))

    @staticmethod
    def admits_radius(xy):
        """What admits a point at radius xy beyond Klipper's: the key to set."""
        return (f"set [printer] print_radius: {math.ceil(xy * 100.0) / 100.0:.2f} (if the arms reach it), or "
                "keep the move nearer the centre")


class RotaryLimits(Limits):
    """Klipper's rotary delta limits (rotary_delta.py's ``check_move``): above ``limit_z``, max_z - Z."""

    def __init__(self, calibration, status, home=None):
        self.max_xy = float(status["axis_maximum"][0])
        self.min_z = float(status["axis_minimum"][2])
        self.max_z = float(status["axis_maximum"][2])
        self.limit_z = min(float(calibration.elbow_coord(k, angle)[2]) - float(lower) for k, (angle, lower)
                           in enumerate(zip(calibration.abs_endstops, calibration.lower_arms)))  # noqa: B905
        self.home = None if home is None else tuple(float(v) for v in home[:3])

    def taper(self, z):
        """The radius Klipper allows at a height z above ``limit_z``: ``max_z - z``."""
        return self.max_z - z

    @staticmethod
    def admits_radius(xy):
        """No key: the arms' reach."""
        return ("the arms' reach, min(shoulder_radius + upper_arm_length, lower_arm_length - "
                "shoulder_radius): no key admits it: keep the move nearer the centre")


def value_keys(printer, steppers):
    """Section key -> (Klipper's section, key, calibration attribute, index): of [printer], per stepper."""
    keys = {key: ("printer", key, attribute, None) for key, attribute in printer}
    for k, tower in enumerate(TOWERS):
        keys.update({f"{key}_{tower}": (f"stepper_{tower}", option, attribute, k)
                     for key, option, attribute in steppers})
    return keys


_STEPPER = (("angle", "angle", "angles"), ("position_endstop", "position_endstop", "endstops"))
#: The linear delta's values (``kinematics: delta``), and the rotary delta's (``rotary_delta``).
VALUE_KEYS = value_keys((("delta_radius", "radius"),), (*_STEPPER, ("arm_length", "arm_length", "arms"),
                                                         ("step_distance", "rotation_distance", "stepdists")))
ROTARY_VALUE_KEYS = value_keys(
    (("shoulder_radius", "shoulder_radius"), ("shoulder_height", "shoulder_height")),
    (*_STEPPER, ("upper_arm_length", "upper_arm_length", "upper_arms"),
     ("lower_arm_length", "lower_arm_length", "lower_arms"), ("step_distance", "gear_ratio", "stepdists")))
#: The kinematics a section is computed for (its ``kinematics``): its values and its limits.
KINEMATICS = {"delta": (VALUE_KEYS, Limits), "rotary_delta": (ROTARY_VALUE_KEYS, RotaryLimits)}


def kinematics_of(config):
    """The section's ``kinematics`` (delta if missing), its values and limits; refused naming the key."""
    kind = config.get("kinematics", "delta")
    if kind not in KINEMATICS:
        raise config.error(f"deltacal_geometry: key kinematics: {kind!r}: this module serves "
                           f"{' and '.join(KINEMATICS)}")
    return kind, KINEMATICS[kind]


#: The section's keys of the volume the correction covers.
VOLUME_KEYS = ("build_radius", "minimum_z", "maximum_z", "coverage_margin")


def read_section(config):
    """The section's grid, its Klipper values and the volume it covers (config.error: the first bad key)."""
    kind = config.get("format")
    if kind != FORMAT:
        raise config.error(f"deltacal_geometry: format {kind!r}: this module reads {FORMAT!r}; copy the "
                           "deltacal_geometry.py written with this section into klippy/extras/")
    values = {key: read_float(config, key) for key in kinematics_of(config)[1][0]}
    volume = {key: read_float(config, key) for key in VOLUME_KEYS}
    origin = config.getfloatlist("grid_origin", count=3)
    finite(origin, "grid_origin", config.error)
    step = read_float(config, "grid_step", above=0.0)
    shape = config.getintlist("grid_shape", count=3)
    curvature = read_curvature(config.get("split_curvature"), shape[2], config.error)
    if min(shape) < 4:
        raise config.error("deltacal_geometry: grid_shape needs 4 nodes or more along each axis")
    unit = read_float(config, "correction_unit", above=0.0)
    correction = decode_values(config.get("correction"), config.error)
    expected = 3 * shape[0] * shape[1] * shape[2]
    if len(correction) != expected:
        raise config.error(f"deltacal_geometry: key correction: {len(correction)} values, expected "
                           f"{expected} (3 per node of grid_shape {tuple(shape)})")
    holds = read_holds(config)
    cells = read_cells(config, shape)
    return CorrectionGrid(origin, step, shape, correction, curvature, unit, holds, cells), values, volume


def read_cells(config, shape):
    """The curvature bound per cell of the grid (``split_cells``), or None (none); refused naming the key."""
    text = config.get("split_cells", "")
    if not text.strip():
        return None
    cells = decode_floats(text, config.error, "split_cells")
    expected = (shape[0] - 1) * (shape[1] - 1) * (shape[2] - 1)
    if len(cells) != expected or not all(0.0 <= v < math.inf for v in cells):
        raise config.error(f"deltacal_geometry: key split_cells: {len(cells)} values, expected {expected} "
                           "non-negative finite ones (1 per cell of grid_shape)")
    return cells


def read_holds(config):
    """Where the calibration holds (:class:`SigmaGrid`), or None (no sigma grid); config.error: the key."""
    bound = read_float(config, "sigma_bound", above=0.0, infinite=True)
    unit = read_float(config, "correction_unit", above=0.0)
    if bound < unit:  # 0.5 bound may be 0: the weights would divide by it
        raise config.error(f"deltacal_geometry: key sigma_bound: {bound!r} is below correction_unit "
                           f"{unit!r}, the resolution of the correction: a bound the weights cannot use "
                           f"(export again with --sigma-bound {unit!r} or more; inf: the whole correction "
                           "everywhere)")
    radius_text = config.get("holds_radius", "")
    if not radius_text.strip():
        return None
    nodes = []
    for key in ("holds_radius", "holds_azimuth", "holds_height"):
        try:
            nodes.append([float(v) for v in config.get(key).split(",")])
        except ValueError as exc:
            raise config.error(f"deltacal_geometry: key {key}: {exc}") from None
        finite(nodes[-1], key, config.error)
    radius, azimuth, height = nodes
    for key, axis in (("holds_radius", radius), ("holds_height", height)):
        if len(axis) < 2 or any(b <= a for a, b in zip(axis, axis[1:])):  # noqa: B905 (Python 3.7+)
            raise config.error(f"deltacal_geometry: key {key}: two increasing values or more")
    if not azimuth:
        raise config.error("deltacal_geometry: key holds_azimuth: one value or more")
    sigma = decode_floats(config.get("holds_sigma"), config.error, "holds_sigma")
    expected = 2 * len(radius) * len(azimuth) * len(height)
    if len(sigma) != expected or not all(0.0 <= v < math.inf for v in sigma):
        raise config.error(f"deltacal_geometry: key holds_sigma: {len(sigma)} values, expected {expected} "
                           "non-negative finite ones (2 per node of holds_radius x holds_azimuth x "
                           "holds_height)")
    return SigmaGrid(radius, azimuth, height, sigma, bound, config.getboolean("holds_significance", True))


def read_float(config, key, above=None, default=None, infinite=False):
    """The section's number under ``key``: Klipper's ``getfloat``, refused (config.error) if not finite.

    Klipper's ``getfloat`` passes ``nan`` and ``inf`` through its bounds. ``infinite``: inf is a value;
    ``default``: the value when the key is missing (None: it must be there).
    """
    if default is None:
        value = config.getfloat(key, above=above)
    else:
        value = config.getfloat(key, default, above=above)
    if not (math.isfinite(value) or (infinite and value == math.inf)):
        what = "not a bound (a number of mm, or inf)" if infinite else "not a finite number"
        raise config.error(f"deltacal_geometry: key {key}: {value!r} is {what} (the section is deltacal's: "
                           "export it again)")
    return value


def finite(values, key, error):
    """Refuse the section's numbers under ``key`` unless all are finite (``error``: the key, the value)."""
    for value in values:
        if not math.isfinite(value):
            raise error(f"deltacal_geometry: key {key}: {value!r} is not a finite number (the section is "
                        "deltacal's: export it again)")


def read_curvature(text, layers, error):
    """The bound of the correction's curvature: a line per ring, a value per z node, non-negative, finite."""
    try:
        rows = [[float(v) for v in line.split(",")] for line in text.split("\n") if line.strip()]
    except ValueError as exc:
        raise error(f"deltacal_geometry: key split_curvature: {exc}") from None
    for row in rows:
        finite(row, "split_curvature", error)
    if not rows or any(len(row) != layers or min(row) < 0.0 for row in rows):
        raise error(f"deltacal_geometry: key split_curvature: a line per ring of {layers} non-negative "
                    "values (one per z node of grid_shape)")
    return rows


def decode_values(text, error):
    """The correction's values from the section's text: base64 of zlib-compressed little-endian int32."""
    try:
        data = zlib.decompress(base64.b64decode("".join(text.split()), validate=True))
    except (ValueError, zlib.error) as exc:
        raise error(f"deltacal_geometry: key correction: not deltacal's encoded values ({exc})") from None
    values = array("i")
    if values.itemsize != 4 or len(data) % 4:
        raise error("deltacal_geometry: key correction: not a whole number of 32-bit values")
    values.frombytes(data)
    if sys.byteorder != "little":
        values.byteswap()
    return values


def decode_floats(text, error, key):
    """Float values from the section's text: base64 of zlib-compressed little-endian float64."""
    try:
        data = zlib.decompress(base64.b64decode("".join(text.split()), validate=True))
    except (ValueError, zlib.error) as exc:
        raise error(f"deltacal_geometry: key {key}: not deltacal's encoded values ({exc})") from None
    values = array("d")
    if values.itemsize != 8 or len(data) % 8:
        raise error(f"deltacal_geometry: key {key}: not a whole number of 64-bit values")
    values.frombytes(data)
    if sys.byteorder != "little":
        values.byteswap()
    return values


def klipper_values(calibration, keys=VALUE_KEYS):
    """The section's values from Klipper's calibration (``kinematics.get_calibration()``), or None (not its).

    None when the calibration lacks an attribute of ``keys`` (another kinematics').
    """
    if not all(hasattr(calibration, attribute) for _, _, attribute, _ in keys.values()):
        return None
    return {key: getattr(calibration, attribute) if k is None else getattr(calibration, attribute)[k]
            for key, (_, _, attribute, k) in keys.items()}


def check_values(ours, klipper, error, keys=VALUE_KEYS):
    """Refuse Klipper's values if any is not the one the correction was computed for (``error``)."""
    for key, (section, option, _, _) in keys.items():
        now, then = float(klipper[key]), ours[key]
        if abs(now - then) > SAME_VALUE * max(1.0, abs(then)):
            what = " (its step distance)" if key.startswith("step_distance") else ""
            raise error(f"deltacal_geometry: [{section}] {option}{what} is {now:.9g} in Klipper, but the "
                        f"correction was computed for {then:.9g}: export it again for the values Klipper "
                        "runs (deltacal export CAL.toml --controller klipper --config printer.cfg --live -o "
                        "DIR), or remove [include deltacal_geometry.cfg]")


def check_volume(volume, limits, error):
    """Refuse Klipper's limits if they reach beyond the volume the correction covers (``error``)."""
    margin = volume["coverage_margin"]
    beyond = []
    if limits.max_xy > volume["build_radius"] + margin:
        beyond.append(f"its build radius {limits.max_xy:.4f} (print_radius) is beyond the "
                      f"{volume['build_radius']:.4f} covered")
    if limits.min_z < volume["minimum_z"] - margin:
        beyond.append(f"minimum_z_position {limits.min_z:g} is below the {volume['minimum_z']:g} covered")
    if limits.max_z > volume["maximum_z"] + margin:
        beyond.append(f"its top {limits.max_z:g} is above the {volume['maximum_z']:g} covered")
    if beyond:
        raise error(f"deltacal_geometry: Klipper's [printer] limits reach beyond the correction's volume "
                    f"({'; '.join(beyond)}, {margin:g} mm allowed): export it again for the values Klipper "
                    "runs, or remove [include deltacal_geometry.cfg]")


def load_config(config):
    """Klipper's entry point for the ``[deltacal_geometry]`` section."""
    return DeltacalGeometry(config)
