//! What a concealed effect leaves in a recording, measured with the truth (for the
//! evaluation of generated recordings, whose true parameters are known): the selection
//! statistics of the true model against the true model with the effect switched off, both
//! replayed exactly as the diagnosis replays its candidates. No fit is involved, so this is
//! the most any diagnosis could see of the effect: an effect whose `z` stays below the
//! selection rule's lowest threshold (`search::RULE.z_floor`) is below the detection limit of
//! this recording, whatever the method.

use super::effect::Effect;
use super::model::{effect_specs, out_of_fold, Layout, Model, Part, Prediction, Split};
use super::refit::Refit;
use super::replay::{Bench, Load};
use super::select::{compare, Comparison};
use super::series::Series;
use super::starts::off_start;
use std::f64::consts::PI;
use tbm_thrust::variables::Params;

/// The comparison of the true model with the true model without `effect`, or `None` when
/// the effect's part is not replayed (an idle pump) or cannot show it (a dead time or flow
/// limit of a pump without its drive command and its commanded flow, or with a chattering
/// command). The true model carries the bench's own flow loop (`controller` and its
/// gains), so a pump replayed through its reconstructed loop is judged with the true loop.
pub fn detectability(series: &Series, truth: &Params, effect: Effect) -> Option<Comparison> {
    judged(series, truth, effect, None)
}

/// The comparison of the true model with the nominal model the diagnosis refitted (stage 2,
/// `refit`), `None` as for [`detectability`]. The refit's unknowns can take up part of an
/// effect (a lower `beta_e` for entrained air, more leakage for a relief valve open on the
/// sliding pressure): what is left is what a diagnosis that refits them has to find. A
/// guide, not a bound: the true model carries the true nominal parameters too (a refit
/// stopped in a wrong minimum raises the figure), a candidate refits the nominal unknowns
/// on each fold (it can beat the refit where the truth does not), and two effects in one
/// part are judged together (the true model carries both).
pub fn beyond_refit(
    series: &Series,
    truth: &Params,
    effect: Effect,
    refit: &Refit,
) -> Option<Comparison> {
    let part = Part::of(effect);
    let nominal = refit.parts.iter().find(|r| r.part == part)?;
    judged(series, truth, effect, Some(&nominal.nominal.prediction))
}

/// The true model's best comparison with `reference`, or with the true model without
/// `effect` when there is none.
fn judged(
    series: &Series,
    truth: &Params,
    effect: Effect,
    reference: Option<&Prediction>,
) -> Option<Comparison> {
    let bench = Bench::new(series);
    let part = Part::of(effect);
    let mut notes = Vec::new();
    if !super::prepare::active_parts(&bench, &mut notes).contains(&part)
        || !part.shows(&bench, effect)
    {
        return None;
    }
    let load = if series.has("F_L") {
        Load::Recorded
    } else {
        super::prepare::initial_load(&bench, truth, &mut notes)
    };
    let with = Model {
        params: truth.clone(),
        load,
    };
    let layout = Layout::new(series);
    let segs = layout.of(part);
    let predict =
        |m: &Model| out_of_fold(&bench, &[m.clone(), m.clone()], part, segs, Split::Blocked);
    let without;
    let reference = match reference {
        Some(r) => r,
        None => {
            let specs = effect_specs(effect, truth, &bench);
            without = predict(&with.with(&specs, &off_start(effect, &specs)));
            &without
        }
    };
    phases(effect, &with)
        .iter()
        .map(|m| compare(&bench, part, segs, reference, &predict(m), Split::Blocked))
        .max_by(|a, b| a.z.total_cmp(&b.z))
}

/// The true model, and for a ripple the true model at 16 phases: a logger's clock offset
/// shifts the recorded time base, and with it the phase of a ripple on that time base.
fn phases(effect: Effect, truth: &Model) -> Vec<Model> {
    let Effect::FlowRipple(_) = effect else {
        return vec![truth.clone()];
    };
    let name = effect.model_parameters()[2];
    (0..16)
        .map(|k| {
            let mut m = truth.clone();
            let phase = truth.params.get(name).expect("ripple phase") + k as f64 * PI / 8.0;
            m.params
                .set(name, (phase + PI).rem_euclid(2.0 * PI) - PI)
                .expect("a phase within +-pi");
            m
        })
        .collect()
}
