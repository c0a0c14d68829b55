"""The model study of issue 19: the paper's 48-run sweep for every model variant and ablation, as one table.

Each variant is the shipped ``config/sim.yaml`` with a few values changed (one mechanism on or off, or a
combination); nothing is keyed by amplitude, frequency or cell. For each it runs Table I's grid (3 gaits x
4 pressures x 4 frequencies, 15 s), the serpentine at 4 bar on anisotropic friction, and one 15 s inward
roll at 4 bar 1 Hz in this process (largest bend, real-time factor on one core, the tail's spin about its
own axis per cycle and the highest point of the body), then prints one row of
:mod:`srs_ros.experiments.fidelity` figures per variant (markdown) and writes them to ``--csv``.

Run: python benchmarks/model_study.py [--variants shipped,no_skin,...] [--duration-s 15] [--workers N]
     [--scheduler tcp://HOST:8786] [--sim-config FILE] [--set SECTION.KEY=VALUE ...] [--csv study.csv]
``--list`` prints the variants; ``--probe`` runs only a quick probe of each (3 inward rolls in this process:
distance per cycle, bend, the tail's spin per cycle, highest point). A run of every variant takes about
1.5 min per variant on 2 cores (4 min on one worker).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir
from srs_ros.core.schema import parse_assignments
from srs_ros.experiments.cluster import add_runner_arguments, runner_from_args
from srs_ros.experiments.fidelity import fidelity_figures
from srs_ros.experiments.sweep import SweepGrid
from srs_ros.experiments.table import cell_key, paper_table
from srs_ros.sim.config import SimConfig, changed_values, load_sim_config, sim_config_from_dict, to_dict
from srs_ros.sim.experiment import run_experiment


@dataclass(frozen=True)
class Variant:
    """A named change of the shipped configuration: ``{"section.key": value}``, and why it is tried."""

    name: str
    changes: dict
    why: str

    def config(self, base: SimConfig) -> SimConfig:
        data = to_dict(base)
        for path, value in self.changes.items():
            section, key = path.split(".")
            data[section][key] = value
        return sim_config_from_dict({"sim": data}, source=f"{base.source} + {self.name}")


def configured(path: str | None, changes: list[str]) -> SimConfig:
    """The simulation config of ``path`` (default config/sim.yaml) with ``section.key=value`` changes (YAML values)."""
    config = load_sim_config(path)
    if not changes:
        return config
    values = parse_assignments(changes, "--set", "muscles.pressure_time_constant_s=0.3")
    for name in values:
        if name.count(".") != 1:
            raise ConfigurationError(f"--set {name}: expected SECTION.KEY=VALUE, e.g. "
                                     "muscles.pressure_time_constant_s=0.3 (the sections of config/sim.yaml's sim:).")
    try:
        return Variant(" ".join(changes), values, "command line").config(config)
    except KeyError as exc:
        raise ConfigurationError(f"--set: no section {exc} in the sim configuration; expected one of "
                                 f"{sorted(to_dict(config))}.") from None


_AUTHORS_BEND = 1.5 * 1750.0 * 0.0125 ** 2     # 3 muscles of 1750 N/m at r = 12.5 mm (Arachchige et al. 2023)
_TETHER_RIGID_SLIP = {"tether.enabled": True, "tether.twist_stiffness_nm2": 0.2, "tether.bend_stiffness_nm2": 0.3,
                      "tether.damping_nms_per_rad": 0.01, "tether.anchor_slip_torque_nm": 0.1}
_LIMIT = {"servo.bend_moment_limit_nm": 0.2}     # the muscles' force limit at 4 bar (N m per module)


def _changes_in(file_name: str) -> dict:
    """The ``{"section.key": value}`` by which a sim YAML of config/ differs from config/sim.yaml."""
    return changed_values(load_sim_config(config_dir() / file_name), load_sim_config())


def _tubes(hold_nm_per_rad: float) -> dict:
    """The supply tubes' twist held by a spring on the tail's spin (N m/rad), lightly damped."""
    return {"contact.roll_stiffness_nm_per_rad": hold_nm_per_rad, "contact.roll_damping_nms_per_rad": 0.002}


VARIANTS = [Variant(*v) for v in (
    ("shipped", {}, "config/sim.yaml as shipped"),
    ("no_skin", {"servo.skin_bend_stiffness_nm_per_rad": 0.0, "servo.skin_axial_stiffness_n_per_m": 0.0},
     "ablation: the muscles alone set the shape (the body reaches the kinematic model's bend)"),
    ("soft_skin", {"servo.skin_bend_stiffness_nm_per_rad": 1.0},
     "the skin takes a third of the bend instead of 60 %"),
    ("authors_muscles", {"servo.bend_stiffness_nm_per_rad": round(_AUTHORS_BEND, 3),
                         "servo.skin_bend_stiffness_nm_per_rad": 0.0},
     "bend stiffness of the authors' dynamic model: muscles of 1750 N/m, no skin spring"),
    ("line_lag", {"muscles.pressure_time_constant_s": 0.2},
     "supply lines: P = 100 l fitted at 1 Hz against 0.065 m static at 4 bar suggests 40 % attenuation at 1 Hz"),
    ("line_lag_delay", {"muscles.pressure_time_constant_s": 0.2, "muscles.transport_delay_s": 0.1},
     "the same with a longer transport delay (3 m of 4 mm tube)"),
    ("carpet", {"contact.contact_time_constant_s": 0.02, "contact.friction_coefficient": 0.4},
     "compliant carpet contact (20 ms) with a low friction coefficient (the authors' penalty contact)"),
    ("rolling_resistance", {"contact.rolling_friction_m": 0.005},
     "ten times the rolling resistance (skin sinking into carpet)"),
    ("combined", {"muscles.pressure_time_constant_s": 0.2, "contact.contact_time_constant_s": 0.02,
                  "contact.friction_coefficient": 0.4, "servo.skin_bend_stiffness_nm_per_rad": 1.0},
     "line lag + carpet + soft skin"),
    ("high_friction", {"contact.friction_coefficient": 1.5},
     "rubber gripping carpet fibres: the top of the calibration's range"),
    ("roll_damping", {"contact.roll_damping_nms_per_rad": 0.02},
     "viscous resistance to the body spinning about its axis (dragged supply lines, carpet hysteresis)"),
    ("roll_damping_line_lag", {"contact.roll_damping_nms_per_rad": 0.02, "muscles.pressure_time_constant_s": 0.2},
     "roll damping with the supply lines' lag"),
    ("segments_3", {"body.segments_per_module": 3}, "coarser body (cost and sensitivity)"),
    # Issue 19, flip / crankshaft hypothesis: can the body lift its middle or ends and tumble about its chord?
    ("twist_soft", {"servo.twist_stiffness_nm_per_rad": 0.02},
     "torsion: each module may twist about its axis (0.02 N m/rad, a tenth of a rubber sleeve's GJ/L)"),
    ("muscle_tendons", {"servo.drive": "muscle_tendons"},
     "muscles as springs along their own lines (1750 N/m, the authors' model) with the shipped skin"),
    ("muscle_tendons_authors", {"servo.drive": "muscle_tendons", "servo.skin_bend_stiffness_nm_per_rad": 0.2,
                                "servo.skin_axial_stiffness_n_per_m": 0.0, "body.mass_per_module_kg": 0.2},
     "the authors' dynamic model: tendon muscles of 1750 N/m, 0.2 kg per section, only a rubber sleeve's "
     "bending stiffness (0.2 N m/rad, config/sim.yaml estimate)"),
    ("spin_restrained", {"contact.roll_damping_nms_per_rad": 0.3},
     "a body that can hardly spin about its axis (roll damping 15x roll_damping's): does the shape tumble instead?"),
    ("spin_restrained_authors", {"servo.drive": "muscle_tendons", "servo.skin_bend_stiffness_nm_per_rad": 0.2,
                                 "servo.skin_axial_stiffness_n_per_m": 0.0, "body.mass_per_module_kg": 0.2,
                                 "contact.roll_damping_nms_per_rad": 0.3},
     "muscle_tendons_authors with the spin restrained"),
    ("spin_restrained_twist", {"contact.roll_damping_nms_per_rad": 0.3, "servo.twist_stiffness_nm_per_rad": 0.02},
     "the spin restrained at the tail, the body free to twist: does the twist relax what would force a tumble?"),
    # Issue 19, the supply tubes: a restraint on the body's spin that grows with its turns, not their rate.
    ("tether_loose", {"tether.enabled": True},
     "the nine supply tubes as one bundle on the floor, clamped 1.25 m behind the tail (loose tubes: GJ 1.9e-3, "
     "EI 2.9e-3 N m^2, config/sim.yaml estimates)"),
    ("tether_tied", {"tether.enabled": True, "tether.twist_stiffness_nm2": 0.024, "tether.bend_stiffness_nm2": 0.03,
                     "tether.damping_nms_per_rad": 0.002},
     "the same bundle tied together (the outer tubes stretch helically: GJ 2.4e-2, EI 3e-2 N m^2, estimate)"),
    ("tether_rigid", {"tether.enabled": True, "tether.twist_stiffness_nm2": 0.2, "tether.bend_stiffness_nm2": 0.3,
                      "tether.damping_nms_per_rad": 0.01},
     "the limit of a spin held by the tubes: ten times the tied bundle's GJ and EI (0.2, 0.3 N m^2; "
     "not a tube estimate)"),
    ("tether_rigid_far", {"tether.enabled": True, "tether.twist_stiffness_nm2": 0.2,
                          "tether.bend_stiffness_nm2": 0.3,
                          "tether.damping_nms_per_rad": 0.01, "tether.length_m": 3.0, "tether.links": 30},
     "tether_rigid anchored 3 m away: how much of its pattern is the leash guiding the robot round the anchor?"),
    ("tether_tied_slip", {"tether.enabled": True, "tether.twist_stiffness_nm2": 0.024,
                          "tether.bend_stiffness_nm2": 0.03, "tether.damping_nms_per_rad": 0.002,
                          "tether.anchor_slip_torque_nm": 0.005},
     "the tied bundle's twist slips above 5 mN m (the bundle turning on the floor about its axis: 0.5 x 0.83 N/m x "
     "1.9 m x 6 mm, estimate)"),
    ("tether_rigid_slip", _TETHER_RIGID_SLIP,
     "stiff but bounded: tether_rigid slipping above 0.1 N m (a third of the torque at which the tied bundle "
     "tumbled the body; not an estimate)"),
    # Issue 19, a flow-limited supply: a muscle fills and vents no faster than the line lets air through.
    ("flow_limit", {"muscles.max_pressure_rate_bar_per_s": 5.0},
     "the muscles fill and vent at most 5 bar/s (estimate: a 0-4 bar sine at 1 Hz then reaches 60 % of its "
     "swing, the attenuation that P = 100 l fitted at 1 Hz against 0.065 m static at 4 bar suggests)"),
    ("flow_limit_slow", {"muscles.max_pressure_rate_bar_per_s": 2.5},
     "half that rate (longer or thinner lines): every rolling cell above 0.6 Hz rate-limited at 4 bar"),
    ("flow_limit_roll_damping", {"muscles.max_pressure_rate_bar_per_s": 5.0, "contact.roll_damping_nms_per_rad": 0.02},
     "flow_limit with roll_damping's viscous resistance to the spin"),
    ("axis_points", {"contact.floor_contact": "points"},
     "floor contact at one sphere per segment (5 per module) on the axis instead of continuous capsules"),
    ("lobed_points", {"contact.floor_contact": "points", "contact.points_around": 3},
     "floor contact at 3 spheres around the skin per segment, at the muscles: a lobed cross-section"),
    # Issue 19, the muscles' force limit (srs_ros/sim/moment_limit.py): with the sleeve-only skin of the authors'
    # body, a module's bending moment at most 0.2 N m at 4 bar (estimate: 10-40 N per muscle at about 0.01 m).
    ("moment_limit", {**_LIMIT, "servo.skin_bend_stiffness_nm_per_rad": 0.2},
     "a module bends with at most 0.2 N m at 4 bar, scaled by its pressure (muscle force x arm, estimate), "
     "against the rubber sleeve alone (0.2 N m/rad)"),
    ("moment_limit_tether", {**_LIMIT, "servo.skin_bend_stiffness_nm_per_rad": 0.2, **_TETHER_RIGID_SLIP},
     "moment_limit with tether_rigid_slip's spin hold: the held C cannot lift itself off the floor"),
    ("tubes_twist", _tubes(0.5),
     "the supply tubes' twist alone: a 0.5 N m/rad spring on the tail's spin, anchored to the world (not measured: "
     "the tubes' own torsion is 0.002-0.02, a tied bundle stretched helically about 0.03-0.04 with the rig's "
     "4/2.5 mm tubes)"),
    ("moment_limit_tubes", {**_LIMIT, "servo.skin_bend_stiffness_nm_per_rad": 0.25, **_tubes(0.5)},
     "moment_limit (skin 0.25 N m/rad) with tubes_twist: the tubes hold the spin, the muscles cannot lift the C"),
    ("moment_limit_tubes_skin_0.3", {**_LIMIT, "servo.skin_bend_stiffness_nm_per_rad": 0.3, **_tubes(0.5)},
     "moment_limit_tubes with a skin of 0.3 N m/rad (how sensitive the trends are to the sleeve)"),
    ("moment_limit_tubes_line_lag", {**_LIMIT, "servo.skin_bend_stiffness_nm_per_rad": 0.25, **_tubes(0.5),
                                     "muscles.pressure_time_constant_s": 0.2},
     "moment_limit_tubes with line_lag's 0.2 s supply lines (less bend at high frequency)"),
    ("moment_limit_soft_tubes_line_lag", _changes_in("sim_held_spin.yaml"),
     "moment_limit_tubes_line_lag with a 0.2 N m/rad hold (the tied bundle's estimate: "
     "0.03-0.04 with the rig's tubes): "
     "config/sim_held_spin.yaml, shipped as a named file since stop 50"),
)]


@dataclass(frozen=True)
class Probe:
    """One inward roll in this process: how far per cycle, how bent, how high, how much the tail spins."""

    cm_per_cycle: float
    bend_deg: float
    target_bend_deg: float
    spin_turns_per_cycle: float
    top_cm: float
    realtime: float


def roll_probe(config: SimConfig, amplitude_bar: float, frequency_hz: float, duration_s: float) -> Probe:
    """Inward rolling in this process: net distance per cycle, largest total bend (deg, simulated and the
    kinematic model's), how many turns per cycle the tail spins about its own axis (1 = a rolling pin: the
    bend stays put and the material rolls inside it; 0 = the shape turns with the material, as a
    crankshaft or a flipping arc), the highest node above the floor (cm: a body lifting its middle or
    ends) and the real-time factor."""
    up_angle, height = [], []

    def on_frame(state) -> None:
        w, x, y, z = state.base_quaternion_wxyz
        # World up in the tail segment's frame: its angle in the segment's x-y plane.
        up_angle.append(math.atan2(2 * (x * z - w * y), 2 * (y * z + w * x)))
        height.append(float(state.nodes_m[:, 2].max()))

    result = run_experiment("inward_rolling", amplitude_bar, frequency_hz, duration_s, config, on_frame=on_frame)
    cycles = duration_s * frequency_hz
    turns = np.unwrap(np.array(up_angle))
    v = result.velocity
    return Probe(100 * math.hypot(v.displacement_x_m, v.displacement_y_m) / cycles,
                 math.degrees(result.peak_body_bend_rad), math.degrees(result.peak_target_bend_rad),
                 abs(turns[-1] - turns[0]) / (2 * math.pi) / cycles, 100 * max(height), result.realtime_factor)


#: The quick probe (--probe): the paper's farthest and shortest steps per cycle, and the 4 bar 1 Hz roll.
PROBE_CELLS = ((4.0, 0.25, 12.0), (2.0, 1.0, 6.0), (4.0, 1.0, 6.0))
PAPER_CM_PER_CYCLE = {(4.0, 0.25): 32.7, (2.0, 1.0): 5.5, (4.0, 1.0): 11.6}   # Table I, inward rolling


def probe_rows(variant: Variant, base: SimConfig) -> list[dict]:
    """The quick probe of one variant: a row per cell of :data:`PROBE_CELLS`."""
    config, rows = variant.config(base), []
    for bar, hz, duration_s in PROBE_CELLS:
        p = roll_probe(config, bar, hz, duration_s)
        rows.append({"variant": variant.name, "cell": f"{bar:g} bar {hz:g} Hz",
                     "cm/cycle (paper)": f"{p.cm_per_cycle:.1f} ({PAPER_CM_PER_CYCLE[(bar, hz)]:g})",
                     "bend deg (kinematic)": f"{p.bend_deg:.0f} ({p.target_bend_deg:.0f})",
                     "spin turns/cycle": f"{p.spin_turns_per_cycle:.2f}", "top cm": f"{p.top_cm:.1f}",
                     "real time x": f"{p.realtime:.1f}"})
    return rows


def study_variant(variant: Variant, base: SimConfig, runner, duration_s: float) -> dict:
    """Every figure of one variant (a row of the table)."""
    config = variant.config(base)
    reference = paper_table()
    grid = SweepGrid.of_table(reference, duration_s)
    records = runner.run(grid.cells(), duration_s, config, keep_track=True)
    figures = fidelity_figures(records, reference)
    anisotropic = config.replace("contact", friction="anisotropic")
    serpentine = runner.run([cell_key("serpentine", 4.0, f) for f in reference.frequencies_hz], duration_s,
                            anisotropic, keep_track=False)
    probe = roll_probe(config, 4.0, 1.0, duration_s)
    bend_deg, realtime, spin, lift_cm = probe.bend_deg, probe.realtime, probe.spin_turns_per_cycle, probe.top_cm
    return {"variant": variant.name, "within 2x": str(figures.within_factor), "rms log": f"{figures.rms_log:.2f}",
            "amplitude trend": str(figures.amplitude_trend), "cycle trend": str(figures.cycle_distance_trend),
            "inward > outward": str(figures.inward_faster), "1 bar still": str(figures.still_cells),
            "serpentine top cm/s": f"{figures.serpentine_top_cm_s:.2f}",
            "serpentine aniso. cm/s": f"{min(r.speed_cm_s for r in serpentine):.2f}-"
                                      f"{max(r.speed_cm_s for r in serpentine):.2f}",
            "bend 4 bar deg": f"{bend_deg:.0f}", "spin turns/cycle": f"{spin:.2f}", "top cm": f"{lift_cm:.1f}",
            "turn deg/cycle": f"{figures.turning_deg_per_cycle:.1f}",
            "reversing runs": str(figures.reversing_runs), "in left, out right": str(figures.rolling_sides),
            "real time x": f"{realtime:.1f}"}


def _markdown(rows: list[dict]) -> str:
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + " --- |" * len(keys)]
    lines += ["| " + " | ".join(row[k] for k in keys) + " |" for row in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default=",".join(v.name for v in VARIANTS))
    parser.add_argument("--duration-s", type=float, default=paper_table().duration_s)
    add_runner_arguments(parser)
    parser.add_argument("--sim-config", default=None,
                        help="the configuration the variants change (default: config/sim.yaml), e.g. a calibrated one")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="change one value of that configuration before the variants, e.g. "
                             "muscles.pressure_time_constant_s=0.3 (repeatable)")
    parser.add_argument("--csv", default=None, help="write the table here too")
    parser.add_argument("--list", action="store_true", help="print the variants and exit")
    parser.add_argument("--probe", action="store_true",
                        help="only the quick probe in this process: inward rolling at 4 bar 0.25 Hz (12 s), 2 bar "
                             "1 Hz and 4 bar 1 Hz (6 s): cm per cycle, bend, tail spin, highest point")
    args = parser.parse_args(argv)
    known = {v.name: v for v in VARIANTS}
    if args.list:
        print("\n".join(f"{v.name}: {v.why} {v.changes}" for v in VARIANTS))
        return 0
    names = [n.strip() for n in args.variants.split(",") if n.strip()]
    unknown = [n for n in names if n not in known]
    if unknown:
        print(f"unknown variant {unknown[0]!r}; expected some of {sorted(known)} (--list explains them)",
              file=sys.stderr)
        return 2
    try:
        base, rows = configured(args.sim_config, args.set), []
    except ConfigurationError as exc:
        print(exc, file=sys.stderr)
        return 2
    if args.probe:
        for name in names:
            rows += probe_rows(known[name], base)
            print(f"probed {name}", file=sys.stderr)
        print(_markdown(rows))
        return 0
    with runner_from_args(args, log=lambda text: print(text, file=sys.stderr)) as runner:
        for i, name in enumerate(names, 1):
            started = time.perf_counter()
            rows.append(study_variant(known[name], base, runner, args.duration_s))
            print(f"[{i}/{len(names)}] {name}: {time.perf_counter() - started:.0f} s  {rows[-1]}", file=sys.stderr)
    print(_markdown(rows))
    if args.csv:
        with open(args.csv, "w", newline="") as stream:
            writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
