import contextlib
import csv
import importlib.util
import os
import shutil
import subprocess
import sys

# small matrices: BLAS threads only contend (see deltacal/__init__.py); set before numpy loads
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from budget import pytest_addoption, pytest_configure  # noqa: E402, F401 (the time budget: tests/budget.py)
from hypothesis import settings  # noqa: E402

from deltacal import NominalDelta  # noqa: E402
from deltacal.io import load_nominal  # noqa: E402
from deltacal.printer.files.robot_file import load_printer  # noqa: E402
from deltacal.printer.firmware.klipper.model import KlipperDelta  # noqa: E402

# every random test is seeded: hypothesis draws the same examples on every machine and run (a
# failure is then a failure of the code, not of the draw), and keeps no example database
settings.register_profile("deltacal", derandomize=True, database=None)
settings.load_profile("deltacal")

ROOT = Path(__file__).resolve().parents[1]
#: The Python packages klippy needs (the ``test`` extra holds them).
KLIPPY_PACKAGES = ("greenlet", "cffi", "jinja2", "markupsafe", "serial")
MODELS = ROOT / "deltacal" / "models"


def kossel_printer_cfg(path: Path, probe_z_offset: float | None = 0.0) -> Path:
    """A printer.cfg as a user writes it, of Klipper's model of the nominal models/kossel.toml.

    Its ``[probe]`` triggers with the nozzle ``probe_z_offset`` above the bed (None: no probe section).
    """
    fw = KlipperDelta.from_printer(load_printer(MODELS / "kossel.toml"))
    text = "[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 3000\n"
    text += f"delta_radius: {fw.delta_radius}\n"
    for k, tower in enumerate("abc"):
        text += (f"\n[stepper_{tower}]\nstep_pin: PF0\ndir_pin: PF1\nenable_pin: !PD7\nmicrosteps: 16\n"
                 f"rotation_distance: 40\nendstop_pin: ^PE4\narm_length: {fw.arm_length[k]}\n"
                 f"position_endstop: {fw.position_endstop[k]}\n")
    if probe_z_offset is not None:
        text += f"\n[probe]\npin: ^PA4\nz_offset: {probe_z_offset}\n"
    path.write_text(text)
    return path


@pytest.fixture(scope="session")
def bai() -> NominalDelta:
    return load_nominal(MODELS / "bai2015.toml")


@pytest.fixture(scope="session")
def flexpicker() -> NominalDelta:
    return load_nominal(MODELS / "flexpicker.toml")


@pytest.fixture(scope="session")
def kossel_plan():
    """The object planned for the shipped Kossel through Klipper's nominal values (``plan_object``'s
    defaults): planned once for every test file that uses it (about a second each time)."""
    from deltacal.printer.printed.plan import plan_object

    printer = load_printer(MODELS / "kossel.toml")
    return plan_object(printer, KlipperDelta.from_printer(printer))


@pytest.fixture(scope="session")
def kossel_object_plan(tmp_path_factory) -> Path:
    """``plan --object`` of the shipped Kossel through its printer.cfg (:func:`kossel_printer_cfg`):
    a folder with printer.cfg and the plan's files in plan/, planned once for the session (about 3 s
    each time). A test file copies it (:func:`copy_object_plan`) before writing beside it."""
    from deltacal.cli import main

    folder = tmp_path_factory.mktemp("kossel_object_plan")
    cfg = kossel_printer_cfg(folder / "printer.cfg")
    assert main(["plan", str(MODELS / "kossel.toml"), "--object", "--controller", str(cfg),
                 "-o", str(folder / "plan")]) == 0
    return folder


def copy_object_plan(planned: Path, folder: Path, plan: str = "plan") -> Path:
    """The session's planned folder (:func:`kossel_object_plan`) copied into ``folder``, its plan's
    files in ``folder / plan``: the copy's printer.cfg."""
    shutil.copy(planned / "printer.cfg", folder / "printer.cfg")
    shutil.copytree(planned / "plan", folder / plan)
    return folder / "printer.cfg"


@pytest.fixture(scope="session")
def kossel_identified(tmp_path_factory, kossel_object_plan) -> Path:
    """The Kossel of :func:`kossel_object_plan` simulated (``--perturb 5``) and identified through its
    printer.cfg: a folder with printer.cfg, obj/ (the plan), probe.csv, d.csv and cal.toml, made once for
    the session. A test file copies it (``shutil.copytree(..., dirs_exist_ok=True)``) before writing."""
    from deltacal.cli import main

    folder = tmp_path_factory.mktemp("kossel_identified")
    cfg = copy_object_plan(kossel_object_plan, folder, "obj")
    plan, kossel = folder / "obj", MODELS / "kossel.toml"
    assert main(["simulate", str(kossel), str(plan / "probe.csv"), str(plan / "distances.csv"),
                 "--controller", str(cfg), "--perturb", "5", "-o", str(folder / "probe.csv"),
                 "--distances-output", str(folder / "d.csv")]) == 0
    assert main(["identify", str(kossel), str(folder / "probe.csv"), str(folder / "d.csv"),
                 "--controller", str(cfg), "-o", str(folder / "cal.toml")]) == 0
    return folder


def workspace_points(nominal: NominalDelta, n: int, rng: np.random.Generator) -> np.ndarray:
    """Random points in the workspace cylinder [mm]."""
    ws = nominal.workspace
    r = ws.radius * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    z = rng.uniform(ws.bottom_z, ws.top_z, n)
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=1)


def write_targets(path, targets) -> None:
    """A targets CSV with every digit of the targets (mm)."""
    path.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in targets.tolist()))


def read_joints(path) -> np.ndarray:
    """The readings of a joints CSV [rad]."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return np.radians([[float(r[f"q{i}_deg"]) for i in (1, 2, 3)] for r in rows])


def complete_fit(nominal: NominalDelta, seed: int):
    """A complete-model fit of a perturbed robot at Bai's 2n + 1 poses (n = 9), 6-DoF pose measurements."""
    from deltacal import Tolerances
    from deltacal.identification import identify
    from deltacal.kinematics import exact
    from deltacal.observations import Measurements
    from deltacal.planning import bai_poses

    rng = np.random.default_rng(seed)
    g0 = nominal.geometry()
    truth = g0.perturbed(Tolerances.bai2015(), rng)
    q = bai_poses(nominal, 9).q
    pose = exact.forward(truth, q)
    position = pose.point(truth.tool) + rng.normal(0.0, 0.005, (len(q), 3))
    return identify(g0, Measurements(q, position, rotation_vector=pose.rotation_vector()), "complete")


@pytest.fixture(scope="session")
def klipper(tmp_path_factory) -> Path:
    """The pinned Klipper (``KLIPPER_DIR``), copied, its C helper built, the live module installed."""
    source = os.environ.get("KLIPPER_DIR")
    if not source:
        pytest.skip("KLIPPER_DIR is not set: the tests against the real Klipper need a copy of it "
                    "(.ci/run sets it to ../shared/vendor/klipper)")
    if not (Path(source) / "klippy" / "klippy.py").is_file():
        pytest.skip(f"KLIPPER_DIR={source}: no klippy/klippy.py there")
    missing = [name for name in KLIPPY_PACKAGES if importlib.util.find_spec(name) is None]
    if missing:
        pytest.skip(f"klippy needs {', '.join(missing)} (pip install '.[test]')")
    if shutil.which("gcc") is None:
        pytest.skip("no gcc: klippy builds its C helper on first start")
    copy = tmp_path_factory.mktemp("klipper") / "klipper"
    shutil.copytree(source, copy, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so", "*.o"))
    subprocess.run([sys.executable, "-c", "import chelper; chelper.get_ffi()"], cwd=copy / "klippy",
                   check=True, timeout=900, capture_output=True)
    from deltacal.printer.firmware.klipper.live.export import module_text

    (copy / "klippy" / "extras" / "deltacal_geometry.py").write_text(module_text(), encoding="utf-8")
    return copy


#: Modules the library imports inside the functions that need them.
IMPORTED_WHERE_NEEDED = ("scipy.stats", "scipy.optimize", "scipy.spatial.transform", "trimesh",
                         "trimesh.creation", "matplotlib.pyplot", "meshcat", "meshcat.geometry",
                         "meshcat.animation")


@pytest.fixture(scope="session", autouse=True)
def _imported_once():
    """What the library imports where it is needed (scipy.stats, scipy.optimize, trimesh, matplotlib,
    meshcat, the command line's subcommands), imported once for the session: a module's import is no
    test's own time (tests/budget.py charges a shared fixture's time to none)."""
    import importlib
    import warnings

    import matplotlib

    matplotlib.use("Agg", force=True)  # as the library does before pyplot (deltacal.report.figures)
    with warnings.catch_warnings():  # meshcat's own imports warn (pyzmq's deprecated event loop)
        warnings.simplefilter("ignore", DeprecationWarning)
        for name in IMPORTED_WHERE_NEEDED:
            with contextlib.suppress(ImportError):
                importlib.import_module(name)
    from deltacal.cli.main import build_parser

    build_parser()  # imports every subcommand's module
