"""TBM shield + cutterhead load model, exported as an FMI 2.0 Co-Simulation FMU by pythonfmu.

It closes the loop around one thrust cylinder: it reads the cylinder motion (x, v) and returns
the external load F_L [N] the cylinder has to push:

    F_target = F_rock + F_shield
    F_rock   = F_pre + F_seat (1 - exp(-max(x, 0) / d_seat)) + k_pen * p_rev
    p_rev    = max(v, 0) / n_rev                        penetration per cutterhead revolution [m/rev]
    F_shield = F_skin * tanh(v / v_eps)                  shield skin friction, regularised Coulomb
    tau_load dF_L/dt = F_target - F_L                    ground + cutterhead-bearing compliance

Numbers are scaled to the single-cylinder test bench of the paper (7 kN ... 12 kN): at rest the
face preload is 7 kN; advancing at 0.05 m/s with the discs seated the load is 12 kN.

The lag tau_load is physical (the reaction builds through the compliance of the cutterhead
bearing and the ground) and also keeps an explicit co-simulation coupling well posed: the load
is a state of this FMU, not an algebraic function of the cylinder velocity.

Build:  pythonfmu build -f ShieldCutterhead.py -d <dir>
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

#: Default parameters [SI]; the FMU exposes each as a tunable parameter of the same name.
DEFAULTS = {
    "F_pre": 7000.0,  # N      face preload with the machine at rest
    "F_seat": 1500.0,  # N      extra rock force once the discs are seated
    "d_seat": 0.005,  # m      penetration over which the discs seat
    "n_rev": 1.0,  # rev/s  cutterhead speed
    "k_pen": 40000.0,  # N per (m/rev) of penetration: specific cutting resistance
    "F_skin": 1500.0,  # N      shield skin friction while advancing
    "v_eps": 0.025,  # m/s    friction regularisation velocity
    "tau_load": 0.05,  # s      load build-up time constant
}


def target_load(x, v, p=DEFAULTS):
    """Quasi-static load F_target [N] and its parts (F_rock, F_shield, p_rev) at motion (x, v)."""
    p_rev = max(v, 0.0) / p["n_rev"]
    f_rock = p["F_pre"] + p["F_seat"] * (1.0 - math.exp(-max(x, 0.0) / p["d_seat"])) + p["k_pen"] * p_rev
    f_shield = p["F_skin"] * math.tanh(v / p["v_eps"])
    return f_rock + f_shield, f_rock, f_shield, p_rev


def lag_step(f_now, f_target, step, tau):
    """Exact update of tau dF/dt = F_target - F over one step with F_target held [N]."""
    return f_target + (f_now - f_target) * math.exp(-step / tau)


class ShieldCutterhead(Fmi2Slave):
    author = "tbm-thrust"
    description = "TBM shield + cutterhead: cylinder motion (x, v) -> rock + shield-friction load F_L [N]"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        # inputs
        self.x = 0.0  # m    cylinder displacement
        self.v = 0.0  # m/s  cylinder velocity
        for name, value in DEFAULTS.items():
            setattr(self, name, value)
        # outputs
        self.F_L = DEFAULTS["F_pre"]  # N  load on the thrust cylinder
        self.F_rock = DEFAULTS["F_pre"]  # N  quasi-static rock force at the face
        self.F_shield = 0.0  # N  quasi-static shield skin friction
        self.p_rev = 0.0  # m/rev penetration per cutterhead revolution

        self.register_variable(Real("x", causality=Fmi2Causality.input, description="Cylinder displacement [m]"))
        self.register_variable(Real("v", causality=Fmi2Causality.input, description="Cylinder velocity [m/s]"))
        for name in DEFAULTS:
            self.register_variable(
                Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable)
            )
        for name, text in [
            ("F_L", "Load on the thrust cylinder [N]"),
            ("F_rock", "Quasi-static rock force at the face [N]"),
            ("F_shield", "Quasi-static shield skin friction [N]"),
            ("p_rev", "Penetration per cutterhead revolution [m/rev]"),
        ]:
            self.register_variable(Real(name, causality=Fmi2Causality.output, description=text))

    def _params(self):
        return {name: float(getattr(self, name)) for name in DEFAULTS}

    def exit_initialization_mode(self):
        # Start in equilibrium with the initial motion (at rest: the face preload).
        f, self.F_rock, self.F_shield, self.p_rev = target_load(self.x, self.v, self._params())
        self.F_L = f

    def do_step(self, current_time, step_size):
        p = self._params()
        f, self.F_rock, self.F_shield, self.p_rev = target_load(self.x, self.v, p)
        self.F_L = lag_step(self.F_L, f, step_size, p["tau_load"])
        return True
