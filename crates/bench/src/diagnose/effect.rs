//! The contract's catalogue of missing-physics effects: their IDs, the subsystem whose
//! equation carries them, the model parameters that switch them on, and the parameters
//! reported in the `diagnose` JSON (docs/contract.md, "Effects").

use std::collections::BTreeMap;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::{by_name, Params};

/// A subsystem of the plant, named as in the contract's `mismatch[].subsystem`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Subsystem {
    /// Piston force balance, Eq. (1).
    Mechanics,
    /// Working-chamber continuity, Eq. (4).
    Chamber,
    /// A motor-pump unit, Eq. (8).
    Pump(Pump),
}

impl Subsystem {
    pub fn name(self) -> &'static str {
        match self {
            Subsystem::Mechanics => "mechanics",
            Subsystem::Chamber => "chamber",
            Subsystem::Pump(Pump::Main) => "pump1",
            Subsystem::Pump(Pump::Aux) => "pump2",
        }
    }

    /// The recorded signal the subsystem's equation shows in first (the contract's
    /// `mismatch[].signal` for it).
    pub fn signal(self) -> &'static str {
        match self {
            Subsystem::Mechanics => "x",
            Subsystem::Chamber => "p",
            Subsystem::Pump(Pump::Main) => "Q1",
            Subsystem::Pump(Pump::Aux) => "Q2",
        }
    }
}

/// One effect of the contract; pump effects carry their pump.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    StribeckFriction,
    PressureDependentFriction,
    PositionDependentLoad,
    EntrainedAir,
    ReliefLeakage,
    PumpDeadTime(Pump),
    PumpFlowLimit(Pump),
    FlowRipple(Pump),
}

/// Every effect of the contract, pump effects for both pumps.
pub const ALL: [Effect; 11] = [
    Effect::StribeckFriction,
    Effect::PressureDependentFriction,
    Effect::PositionDependentLoad,
    Effect::EntrainedAir,
    Effect::ReliefLeakage,
    Effect::PumpDeadTime(Pump::Main),
    Effect::PumpDeadTime(Pump::Aux),
    Effect::PumpFlowLimit(Pump::Main),
    Effect::PumpFlowLimit(Pump::Aux),
    Effect::FlowRipple(Pump::Main),
    Effect::FlowRipple(Pump::Aux),
];

impl Effect {
    /// The contract's effect ID.
    pub fn id(self) -> &'static str {
        match self {
            Effect::StribeckFriction => "stribeck_friction",
            Effect::PressureDependentFriction => "pressure_dependent_friction",
            Effect::PositionDependentLoad => "position_dependent_load",
            Effect::EntrainedAir => "entrained_air",
            Effect::ReliefLeakage => "relief_leakage",
            Effect::PumpDeadTime(_) => "pump_dead_time",
            Effect::PumpFlowLimit(_) => "pump_flow_limit",
            Effect::FlowRipple(_) => "flow_ripple",
        }
    }

    /// Parses an ID; pump effects take the pump from a `:1` / `:2` suffix (default 1).
    pub fn parse(text: &str) -> Option<Effect> {
        let (id, pump) = match text.split_once(':') {
            Some((id, n)) => (id, n.parse().ok().and_then(Pump::from_number)?),
            None => (text, Pump::Main),
        };
        ALL.iter()
            .copied()
            .find(|e| e.id() == id && e.pump().map_or(true, |p| p == pump))
    }

    /// The pump an effect belongs to, if any.
    pub fn pump(self) -> Option<Pump> {
        match self {
            Effect::PumpDeadTime(i) | Effect::PumpFlowLimit(i) | Effect::FlowRipple(i) => Some(i),
            _ => None,
        }
    }

    /// Whether the effect drives a stick-slip cycle: friction that falls with speed makes the
    /// piston stick and slip at low speed, an oscillation whose phase no replay follows
    /// (`model::features` judges its envelope), so what the fit leaves of it repeats at
    /// every breakaway.
    pub fn drives_stick_slip(self) -> bool {
        self == Effect::StribeckFriction
    }

    /// The subsystem whose equation the effect changes.
    pub fn subsystem(self) -> Subsystem {
        match self {
            Effect::StribeckFriction
            | Effect::PressureDependentFriction
            | Effect::PositionDependentLoad => Subsystem::Mechanics,
            Effect::EntrainedAir | Effect::ReliefLeakage => Subsystem::Chamber,
            Effect::PumpDeadTime(i) | Effect::PumpFlowLimit(i) | Effect::FlowRipple(i) => {
                Subsystem::Pump(i)
            }
        }
    }

    /// Names of the model parameters (variables.toml) that carry the effect.
    pub fn model_parameters(self) -> &'static [&'static str] {
        match self {
            Effect::StribeckFriction => &["F_s", "v_s"],
            Effect::PressureDependentFriction => &["mu"],
            Effect::PositionDependentLoad => &["k_load"],
            Effect::EntrainedAir => &["air_fraction"],
            Effect::ReliefLeakage => &["p_crack", "K_relief"],
            Effect::PumpDeadTime(Pump::Main) => &["delay1"],
            Effect::PumpDeadTime(Pump::Aux) => &["delay2"],
            Effect::PumpFlowLimit(Pump::Main) => &["rate_limit1"],
            Effect::PumpFlowLimit(Pump::Aux) => &["rate_limit2"],
            Effect::FlowRipple(Pump::Main) => &["ripple_amp1", "ripple_freq1", "ripple_phase1"],
            Effect::FlowRipple(Pump::Aux) => &["ripple_amp2", "ripple_freq2", "ripple_phase2"],
        }
    }

    /// The contract's reported parameters, each with the model parameter it is read from
    /// (`None`: the pump's number).
    fn reported_names(self) -> Vec<(&'static str, Option<&'static str>)> {
        let model = self.model_parameters();
        let pump = self.pump().map(|_| ("pump", None));
        let named: Vec<(&'static str, Option<&'static str>)> = match self {
            Effect::StribeckFriction => vec![("F_s", Some("F_s")), ("v_s", Some("v_s"))],
            Effect::PressureDependentFriction => vec![("mu", Some("mu"))],
            Effect::PositionDependentLoad => vec![("k", Some("k_load"))],
            Effect::EntrainedAir => vec![("air_fraction", Some("air_fraction"))],
            Effect::ReliefLeakage => vec![("p_crack", Some("p_crack")), ("K", Some("K_relief"))],
            Effect::PumpDeadTime(_) => vec![("delay", Some(model[0]))],
            Effect::PumpFlowLimit(_) => vec![("rate_limit", Some(model[0]))],
            Effect::FlowRipple(_) => {
                vec![("amplitude", Some(model[0])), ("frequency", Some(model[1]))]
            }
        };
        pump.into_iter().chain(named).collect()
    }

    /// The contract's reported parameters (SI) read from a parameter set.
    pub fn reported(self, p: &Params) -> BTreeMap<String, f64> {
        let pump = self.pump().map_or(f64::NAN, |i| f64::from(i.number()));
        self.reported_names()
            .into_iter()
            .map(|(key, model)| {
                let value = model.map_or(pump, |n| p.get(n).unwrap_or(f64::NAN));
                (key.to_string(), value)
            })
            .collect()
    }

    /// The SI unit of a reported parameter, as modelDescription declares it for the model
    /// parameter it is read from ("1" dimensionless, "" for the pump's number or an unknown
    /// key).
    pub fn reported_unit(self, key: &str) -> &'static str {
        self.reported_names()
            .into_iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, model)| by_name(model?))
            .map_or("", |v| v.unit)
    }

    /// The canonical form in words, for reports.
    pub fn equation(self) -> &'static str {
        match self {
            Effect::StribeckFriction => "F_f = sgn(v)(F_c + (F_s - F_c) exp(-(|v|/v_s)^2)) + b v",
            Effect::PressureDependentFriction => "extra friction sgn(v) mu A p",
            Effect::PositionDependentLoad => "extra load k x",
            Effect::EntrainedAir => {
                "beta_eff(p) with free air fraction a at atmospheric pressure (n = 1.4)"
            }
            Effect::ReliefLeakage => "Q_rel = K max(0, p - p_crack)",
            Effect::PumpDeadTime(_) => "Q_i answers u_ci(t - delay)",
            Effect::PumpFlowLimit(_) => "|dQ_i/dt| <= rate_limit",
            Effect::FlowRipple(_) => "Q_i (1 + r sin(2 pi f t + phi))",
        }
    }
}

/// Lowest frequency a pump ripple can have [Hz]: a piston pump's pulsation runs at
/// (pistons x shaft speed), several hertz even at crawl speed, and a tone must repeat at
/// least 20 times in the recording to be a tone rather than a slow trend.
pub fn min_ripple_frequency(duration: f64) -> f64 {
    2f64.max(20.0 / duration)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_parse_back() {
        for e in ALL {
            let text = match e.pump() {
                Some(i) => format!("{}:{}", e.id(), i.number()),
                None => e.id().to_string(),
            };
            assert_eq!(Effect::parse(&text), Some(e));
        }
        assert_eq!(
            Effect::parse("pump_dead_time"),
            Some(Effect::PumpDeadTime(Pump::Main))
        );
        assert_eq!(Effect::parse("stribeck"), None);
    }

    #[test]
    fn reported_names_follow_the_contract() {
        let p = Params::default();
        let keys: Vec<String> = Effect::FlowRipple(Pump::Aux)
            .reported(&p)
            .into_keys()
            .collect();
        assert_eq!(keys, ["amplitude", "frequency", "pump"]);
        assert_eq!(Effect::ReliefLeakage.reported(&p).len(), 2);
        assert!(Effect::PositionDependentLoad.reported(&p).contains_key("k"));
    }

    #[test]
    fn reported_parameters_carry_the_model_parameters_units() {
        let air = Effect::EntrainedAir;
        assert_eq!(air.reported_unit("air_fraction"), "1");
        let limit = Effect::PumpFlowLimit(Pump::Aux);
        assert_eq!(limit.reported_unit("rate_limit"), "m3/s2");
        assert_eq!(limit.reported_unit("pump"), "");
        assert_eq!(Effect::ReliefLeakage.reported_unit("K"), "m3/(s.Pa)");
        assert_eq!(Effect::StribeckFriction.reported_unit("v_s"), "m/s");
        for e in ALL {
            for key in e.reported(&Params::default()).keys() {
                assert_eq!(
                    e.reported_unit(key).is_empty(),
                    key == "pump",
                    "{e:?} {key}"
                );
            }
        }
    }
}
