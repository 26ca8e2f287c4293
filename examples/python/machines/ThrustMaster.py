"""Master thrust controller of a TBM, exported as an FMI 2.0 Co-Simulation FMU by pythonfmu.

It issues the advance-velocity command v_ref [m/s] of the thrust cylinders through a
start / hold / stop / restart cycle, and stops at the end of the cylinder stroke:

    t <  t_start              v_ref = 0                        phase 0  idle
    t_start <= t < t_stop     v_ref = v_advance (ramped)       phase 1  start, then 2 hold
    t_stop <= t < t_restart   v_ref = 0                        phase 3  stop
    t >= t_restart            v_ref = v_restart (ramped)       phase 4  restart
    x >= x_stroke_end         v_ref = 0                        phase 5  stroke end (regrip)

ramp_time = 0 gives the step command of the paper's start-up test. v_ref is the value for the
communication step that starts at the FMU's current time (zero-order hold).

Build:  pythonfmu build -f ThrustMaster.py -d <dir>
"""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real

DEFAULTS = {
    "v_advance": 0.05,  # m/s  advance velocity after the start
    "v_restart": 0.05,  # m/s  advance velocity after the restart
    "t_start": 0.0,  # s
    "t_stop": 8.0,  # s
    "t_restart": 12.0,  # s
    "ramp_time": 0.0,  # s    0 = step command
    "t_hold_after": 1.0,  # s    start phase shown as 'start' for this long, then 'hold'
    "x_stroke_end": 1.4,  # m    stop before the end of the 1.5 m stroke
}


def command(t, x, p=DEFAULTS):
    """(v_ref [m/s], phase) commanded at time t with the cylinder at stroke x."""
    if x >= p["x_stroke_end"]:
        return 0.0, 5

    def ramp(t0, v):
        if p["ramp_time"] <= 0.0:
            return v
        return v * min(1.0, max(0.0, (t - t0) / p["ramp_time"]))

    if t < p["t_start"] - 1e-12:
        return 0.0, 0
    if t < p["t_stop"] - 1e-12:
        phase = 1 if t < p["t_start"] + p["t_hold_after"] else 2
        return ramp(p["t_start"], p["v_advance"]), phase
    if t < p["t_restart"] - 1e-12:
        return 0.0, 3
    return ramp(p["t_restart"], p["v_restart"]), 4


class ThrustMaster(Fmi2Slave):
    author = "tbm-thrust"
    description = "TBM master thrust controller: v_ref profile start / hold / stop / restart, stroke-end stop"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.x = 0.0  # input: stroke of the cylinder [m]
        for name, value in DEFAULTS.items():
            setattr(self, name, value)
        self.v_ref = 0.0  # output [m/s]
        self.phase = 0  # output: 0 idle, 1 start, 2 hold, 3 stop, 4 restart, 5 stroke end
        self.time = 0.0

        self.register_variable(Real("x", causality=Fmi2Causality.input, description="Cylinder stroke [m]"))
        for name in DEFAULTS:
            self.register_variable(
                Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable)
            )
        self.register_variable(Real("v_ref", causality=Fmi2Causality.output, description="Commanded advance velocity [m/s]"))
        self.register_variable(
            Integer("phase", causality=Fmi2Causality.output, variability=Fmi2Variability.discrete, description="0 idle, 1 start, 2 hold, 3 stop, 4 restart, 5 stroke end")
        )

    def _params(self):
        return {name: float(getattr(self, name)) for name in DEFAULTS}

    def setup_experiment(self, start_time, stop_time, tolerance):
        self.time = start_time

    def exit_initialization_mode(self):
        self.v_ref, self.phase = command(self.time, self.x, self._params())

    def do_step(self, current_time, step_size):
        self.time = current_time + step_size
        self.v_ref, self.phase = command(self.time, self.x, self._params())
        return True
