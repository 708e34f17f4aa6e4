"""Observables of Sen, Manciu & Wright (1998), computed from recorded snapshots and traces.

Pure NumPy: every function takes arrays (xarray DataArrays work too, through ``np.asarray``)
with the store's layout — snapshots ``(..., record, grain)``, traces ``(..., sample)`` — and
program units (length 1e-5 m, time 1.0102e-3 s, mass 2.36e-5 kg). Positions along the chain are
grain indices counted from the surface (grain 0), so speeds are in grains per time unit
(multiply by the diameter, 100 length units, for length per time).

Sign convention: docs/model.md §1's displacement ``u`` and velocity ``v`` are positive *into* the chain
(toward the bottom). The paper plots grain positions, so its displacements are ``−u``
(:func:`paper_displacement`), and a pulse moving into the chain compresses the "negative side
of the y axis".

One module per subject (``from ensemble import analysis as an`` re-exports them all):

* ``common`` — line and power-law fits, the paper's sign convention.
* ``pulses`` — Sec. III: pulse head, speed, speed exponent, shock width, tails, Nesterenko's soliton.
* ``echoes`` — Secs. IV, V: backscattering from impurities at a traced grain.
* ``columns`` — Sec. V: columns under gravity, the depth law, tail bumps.
* ``drive`` — Sec. VI: driven columns, window averages, the standing-wave measure.

Functions that take a whole store (an xarray Dataset of one paper sweep) and reduce it for a
figure — :func:`speeds_table`, :func:`echo_table`, :func:`driven_windows` — live here too, so
``ensemble/plotting/figures.py`` only draws.

What is here, by paper section:

* III A — :func:`pulse_head`, :func:`head_positions`, :func:`pulse_speed`, :func:`speed_history`
  (pulse position and speed c(t)); :func:`speed_exponent` (α in c ∝ v_imp^α);
  :func:`shock_width` (W(t)); :func:`plateau_tilt` (flat vs sloping top, Fig. 4);
  :func:`overlaps`, :func:`overlap_behind_head` (Fig. 2(a)'s higher overlaps behind the front).
* III B — :func:`tail_decay` (exponential tail P(z, t) ∝ exp(−z/λ), compared with c·t).
* IV, V — :func:`backscatter` (arrival, amplitude and leading sign of the echo at a grain);
  :func:`echo_contrast` (how different the light and heavy echoes are); :func:`power_spectrum`,
  :func:`linear_chain_modes`, :func:`hertz_stiffness` (oscillations at an impurity site, linear theory).
* V — :func:`depth_law` (c ∝ z^β, the paper's β = 1/6), :func:`column_sound_speed` (closed form),
  :func:`count_bumps` (tail bumps, Fig. 6).
* VI — :func:`window_average`, :func:`standing_wave_measure`, :func:`profile_correlation` (shape
  correlation against lag); :func:`column_wave_phase`, :func:`fit_two_waves` (forward and backward waves
  at the drive frequency, the standing fraction), :func:`standing_fractions` (per point of a drive sweep); response maps (docs/drive.md):
  :func:`standing_wave_ratio`, :func:`node_drift`, :func:`strobe_label`, :func:`point_response_numbers`,
  :func:`response_map`.
* Nesterenko's long-wave soliton — :func:`nesterenko_speed`, :data:`NESTERENKO_SUPPORT`,
  :data:`NESTERENKO_FWHM`, :func:`full_width_half_maximum`.
"""

from hertzian.studies.analysis.columns import column_sound_speed, count_bumps, depth_law, speed_against_depth
from hertzian.studies.analysis.common import (
    LineFit,
    PowerLawFit,
    energy_drift,
    fit_line,
    fit_power_law,
    paper_displacement,
    paper_label,
)
from hertzian.studies.analysis.drive import (
    LABELS,
    MAP_METRICS,
    PAPER_DRIVE_TIMES,
    PAPER_WINDOW,
    PERSISTENCE_LAGS,
    StandingWave,
    column_wave_phase,
    drive_times,
    driven_windows,
    fit_two_waves,
    kinetic_energy,
    node_drift,
    point_response_numbers,
    profile_correlation,
    profile_nodes,
    response_map,
    standing_fractions,
    standing_verdict,
    standing_wave_measure,
    standing_wave_ratio,
    store_provenance,
    strobe_label,
    strobe_samples,
    surrogate_fractions,
    window_average,
)
from hertzian.studies.analysis.echoes import (
    Backscatter,
    backscatter,
    contrast_table,
    echo_contrast,
    echo_table,
    echo_window,
    first_lobe,
    hertz_stiffness,
    impurity_grains,
    impurity_points,
    linear_chain_modes,
    power_spectrum,
)
from hertzian.studies.analysis.pulses import (
    NESTERENKO_FWHM,
    NESTERENKO_SUPPORT,
    PAPER_TAIL_TIMES,
    TailFit,
    _parabolic_peak,  # noqa: F401  (sub-sample peak position; tests use it)
    front_position,
    full_width_half_maximum,
    head_positions,
    nesterenko_speed,
    overlap_behind_head,
    overlaps,
    plateau_tilt,
    pulse_head,
    pulse_speed,
    rear_level,
    running_max,
    shock_width,
    shock_widths,
    speed_exponent,
    speed_history,
    speeds_table,
    tail_decay,
    times_in_flight,
)

__all__ = [
    "Backscatter",
    "LineFit",
    "NESTERENKO_FWHM",
    "NESTERENKO_SUPPORT",
    "PAPER_DRIVE_TIMES",
    "PAPER_TAIL_TIMES",
    "PAPER_WINDOW",
    "PERSISTENCE_LAGS",
    "PowerLawFit",
    "StandingWave",
    "TailFit",
    "backscatter",
    "column_sound_speed",
    "contrast_table",
    "count_bumps",
    "depth_law",
    "column_wave_phase",
    "drive_times",
    "fit_two_waves",
    "profile_correlation",
    "driven_windows",
    "echo_contrast",
    "echo_table",
    "echo_window",
    "energy_drift",
    "first_lobe",
    "fit_line",
    "fit_power_law",
    "front_position",
    "full_width_half_maximum",
    "head_positions",
    "hertz_stiffness",
    "impurity_grains",
    "impurity_points",
    "kinetic_energy",
    "linear_chain_modes",
    "nesterenko_speed",
    "overlap_behind_head",
    "overlaps",
    "paper_displacement",
    "paper_label",
    "plateau_tilt",
    "power_spectrum",
    "profile_nodes",
    "pulse_head",
    "pulse_speed",
    "rear_level",
    "running_max",
    "shock_width",
    "shock_widths",
    "speed_against_depth",
    "speed_exponent",
    "speed_history",
    "speeds_table",
    "standing_fractions",
    "standing_verdict",
    "store_provenance",
    "surrogate_fractions",
    "standing_wave_measure",
    "tail_decay",
    "times_in_flight",
    "window_average",
    "LABELS",
    "MAP_METRICS",
    "node_drift",
    "point_response_numbers",
    "response_map",
    "standing_wave_ratio",
    "strobe_label",
    "strobe_samples",
]
