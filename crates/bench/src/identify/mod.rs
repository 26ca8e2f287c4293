//! Fitting the model's unknowns to a recording (section 2.3 of the paper).
//!
//! Two stages:
//! 1. **Pumps, subsystem-wise** ([`pump`]): when the recording has a pump's drive command
//!    `uc_i`, that pump's a_i, b_u_i, b_p_i are fitted on Eq. (8) replayed open-loop with
//!    the measured `uc_i` and `p` against the measured `Q_i` (integral-form least squares,
//!    then Levenberg-Marquardt on the simulation error), and used when the replay then
//!    matches the flow to its noise level. Without `uc_i` the pump keeps its parameters and the result
//!    says which pump checks were skipped.
//! 2. **Closed loop**: the named unknowns (by default beta_e, C_ip, b within Table 2) are
//!    fitted by replaying the whole closed loop (Eq. 12 with the controller of section 3)
//!    with the recording's inputs and minimising the cost of section 2.3,
//!    J = sum_k (w_x e_x(k)^2 + w_v e_v(k)^2 + w_p e_p(k)^2), e = measured - model.
//!
//! Weights: w_s = 1 / (N sigma_s^2), with sigma_s the white-noise level of the measured
//! signal s (robust SD of second differences, `numerics::stats::noise_level`), floored at
//! 1e-5 of the signal's range so that a noise-free recording still gets finite weights.
//! J is then dimensionless and about 1 per signal when the model fits to the noise level;
//! a weighting by each signal's variance instead would let the pressure noise swamp the
//! displacement offset that carries C_ip. `v` enters only when the recording has it.
//! As in section 2.3, the first 0.05 s are left out of J (the start-up transient of the
//! sensors); the model is still simulated from the first sample.
//!
//! Methods ([`Method`]): the paper's GA ([`ga`], exactly section 2.3) and the default,
//! differential evolution in log-scaled parameters refined by Levenberg-Marquardt
//! ([`de`], [`lm`]). Both evaluate candidates in parallel with rayon and draw every random
//! number on one thread from a ChaCha8 generator seeded by [`FitOptions::seed`], so the
//! result does not depend on thread scheduling.

mod de;
mod ga;
pub mod pump;

use crate::numerics::bounds::{self, Bounds};
use crate::numerics::lm;
use crate::numerics::stats::noise_level;
use crate::recording::{Recording, Replay, ReplayError};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use pump::PumpFit;
use rayon::prelude::*;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;
use tbm_thrust::metrics::{self, Fit};
use tbm_thrust::params::ParamError;
use tbm_thrust::pump::Pump;
use tbm_thrust::variables::{by_name, Causality, Kind, Params};

/// Samples at the start left out of the cost, as section 2.3 uses 0.05-20 s [s].
pub const SKIP_START_S: f64 = 0.05;
/// The signals of the section 2.3 cost.
pub const COST_SIGNALS: [&str; 3] = ["x", "v", "p"];
/// Signals reported like Table 3, with their SI units.
pub const REPORT_SIGNALS: [(&str, &str); 5] = [
    ("x", "m"),
    ("v", "m/s"),
    ("p", "Pa"),
    ("Q1", "m^3/s"),
    ("Q2", "m^3/s"),
];
/// Floor of a signal's noise level relative to its range (noise-free recordings).
const NOISE_FLOOR: f64 = 1e-5;
/// The local stage of the default method (see `numerics::lm`): Jacobian step 1e-3 in unit
/// coordinates, at most 25 iterations, stop below 1e-7 relative gain.
const LOCAL: lm::Options = lm::Options {
    jacobian_step: 1e-3,
    max_iterations: 25,
    min_gain: 1e-7,
};

/// The optimiser of the closed-loop stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper's genetic algorithm (section 2.3).
    PaperGa,
    /// Differential evolution in log-scaled parameters, then Levenberg-Marquardt.
    Default,
}

impl Method {
    /// The CLI name: `paper-ga` or `default`.
    pub fn name(self) -> &'static str {
        match self {
            Method::PaperGa => "paper-ga",
            Method::Default => "default",
        }
    }

    pub fn from_name(name: &str) -> Option<Method> {
        [Method::PaperGa, Method::Default]
            .into_iter()
            .find(|m| m.name() == name)
    }

    pub fn description(self) -> &'static str {
        match self {
            Method::PaperGa => "paper's GA: floating-point genes, roulette wheel, single-point crossover p = 0.5, adaptive mutation, population 25, <= 100 generations, stop after 10 without 1 % gain",
            Method::Default => "differential evolution (DE/rand/1/bin with dither, log-scaled parameters) refined by Levenberg-Marquardt",
        }
    }
}

/// What to fit and how.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    pub method: Method,
    /// Seed of every random draw; equal seeds give equal results.
    pub seed: u64,
    /// Parameters of the closed-loop stage (names of the variable table).
    pub names: Vec<String>,
    /// Search range of each name, SI, same order.
    pub bounds: Vec<(f64, f64)>,
    /// Draw a progress bar on stderr (only when stderr is a terminal).
    pub progress: bool,
}

impl FitOptions {
    /// The default unknowns (Table 2) with the given method and seed, no progress bar.
    pub fn new(method: Method, seed: u64) -> FitOptions {
        let (names, bounds) = default_unknowns();
        FitOptions {
            method,
            seed,
            names,
            bounds,
            progress: false,
        }
    }
}

/// The outcome of [`fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    /// The base parameters with the fitted values (pumps and unknowns).
    pub params: Params,
    /// Final cost J of the closed-loop stage (dimensionless, see the module docs).
    pub cost: f64,
    /// Closed-loop simulations run.
    pub simulations: usize,
    /// Wall time of the whole fit, both stages [s].
    pub wall_time_s: f64,
    /// Best J after each generation or iteration.
    pub history: Vec<f64>,
    /// Pump stage: one entry per pump fitted (see [`PumpFit::accepted`]).
    pub pumps: Vec<PumpFit>,
    /// What was skipped or assumed, one sentence each.
    pub notes: Vec<String>,
}

/// The paper's unknowns in the order they are fitted and reported.
const DEFAULT_UNKNOWNS: [&str; 3] = ["beta_e", "C_ip", "b"];

/// The paper's unknowns and their Table 2 ranges (`paper_search` in variables.toml):
/// beta_e [Pa], C_ip [m^3/(s Pa)], b [N s/m].
pub fn default_unknowns() -> (Vec<String>, Vec<(f64, f64)>) {
    let range = |n: &str| {
        by_name(n)
            .and_then(|v| v.paper_search)
            .expect("a paper_search range in variables.toml")
    };
    (
        DEFAULT_UNKNOWNS.map(String::from).to_vec(),
        DEFAULT_UNKNOWNS.map(range).to_vec(),
    )
}

/// Why a fit cannot run; `Display` gives one line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("no parameters to fit")]
    NoParameters,
    #[error("{names} parameter names but {ranges} ranges")]
    RangeCount { names: usize, ranges: usize },
    #[error("cannot fit `{0}`: not a real parameter of the model")]
    NotAParameter(String),
    #[error("`{0}` is listed twice")]
    ListedTwice(String),
    #[error("range of `{name}` [{lo}, {hi}] {unit} is empty")]
    EmptyRange {
        name: String,
        lo: f64,
        hi: f64,
        unit: &'static str,
    },
    #[error("range of `{name}` [{lo}, {hi}] {unit} leaves the allowed [{min}, {max}] {unit}")]
    BeyondTable {
        name: String,
        lo: f64,
        hi: f64,
        min: f64,
        max: f64,
        unit: &'static str,
    },
    #[error(transparent)]
    Replay(#[from] ReplayError),
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("{file}: `x` and `p` are constant; there is nothing to fit")]
    NothingToFit { file: String },
    #[error("{file}: no candidate gave a finite cost (every simulation failed)")]
    NoFiniteCost { file: String },
}

/// Fits the pumps (when the recording has their drive commands) and then `opts.names` to
/// the recording, starting from `base`. See the module documentation.
pub fn fit(rec: &Recording, base: &Params, opts: &FitOptions) -> Result<FitResult, FitError> {
    let start = Instant::now();
    check_options(base, opts)?;
    let replay = Replay::new(base, rec)?;
    let mut params = replay.params(base)?;
    let mut notes = replay.notes.clone();
    let pumps = fit_pumps(rec, &mut params, &mut notes)?;

    // Stage 2: the closed loop.
    let objective = Objective::new(rec, replay, params.clone(), &opts.names)?;
    let space = search_space(opts);
    let progress = Progress::new(opts.progress, budget(opts) as u64, opts.method.name());
    let residuals = |v: &[f64]| objective.residuals(v);
    let eval = Evaluator {
        objective: &residuals,
        space: &space,
        simulations: AtomicUsize::new(0),
        progress: &progress,
    };
    let given: Vec<f64> = opts
        .names
        .iter()
        .map(|n| params.get(n).expect("checked"))
        .collect();
    let outcome = search(&eval, &bounds::to_unit(&space, &given), opts);
    progress.finish();
    let values = bounds::to_phys(&space, &outcome.best);
    for (name, value) in opts.names.iter().zip(&values) {
        params.set(name, *value)?;
    }
    if !outcome.cost.is_finite() {
        return Err(FitError::NoFiniteCost {
            file: rec.source.clone(),
        });
    }
    Ok(FitResult {
        params,
        cost: outcome.cost,
        simulations: eval.simulations.load(Ordering::Relaxed),
        wall_time_s: start.elapsed().as_secs_f64(),
        history: outcome.history,
        pumps,
        notes,
    })
}

/// Stage 1: both pumps fitted subsystem-wise (Eq. 8) in parallel; an accepted fit's values
/// go into `params`, and each pump's outcome into `notes`.
fn fit_pumps(
    rec: &Recording,
    params: &mut Params,
    notes: &mut Vec<String>,
) -> Result<Vec<pump::PumpFit>, FitError> {
    let (f1, f2) = rayon::join(
        || pump::fit_pump(rec, params, Pump::Main),
        || pump::fit_pump(rec, params, Pump::Aux),
    );
    let mut pumps = Vec::new();
    for outcome in [f1, f2] {
        match outcome {
            Ok(pf) => {
                if pf.accepted {
                    for (name, value) in pf.names.iter().zip(&pf.values) {
                        params.set(name, *value)?;
                    }
                }
                notes.push(pf.summary());
                pumps.push(pf);
            }
            Err(skipped) => notes.push(skipped.to_string()),
        }
    }
    Ok(pumps)
}

/// The unknowns' ranges as the method searches them: the default method searches positive
/// ranges log-scaled (C_ip spans a factor 50).
fn search_space(opts: &FitOptions) -> Vec<Bounds> {
    opts.bounds
        .iter()
        .map(|&(lo, hi)| match opts.method {
            Method::Default if lo > 0.0 => Bounds::log(lo, hi),
            _ => Bounds::linear(lo, hi),
        })
        .collect()
}

/// The simulations the method runs at most (the progress bar's length).
fn budget(opts: &FitOptions) -> usize {
    match opts.method {
        Method::PaperGa => ga::MAX_SIMULATIONS,
        Method::Default => {
            de::max_simulations(opts.names.len()) + LOCAL.typical_evaluations(opts.names.len())
        }
    }
}

/// The method's search from `start` (unit coordinates): the paper's GA, or differential
/// evolution and then Levenberg-Marquardt.
fn search(eval: &Evaluator, start: &[f64], opts: &FitOptions) -> Outcome {
    match opts.method {
        Method::PaperGa => ga::run(eval, opts.seed),
        Method::Default => {
            let global = de::run(eval, start, opts.seed);
            let local = lm::minimize(&|u| eval.residuals(u), &global.best, &LOCAL);
            eval.report(local.cost);
            Outcome {
                best: local.u,
                cost: local.cost,
                history: [global.history, local.history].concat(),
            }
        }
    }
}

/// R^2, RMSE [SI] and MAPE [%] of the replayed model against the recording, per signal of
/// [`REPORT_SIGNALS`] the recording has and that is not zero throughout, over the samples
/// the cost uses (from 0.05 s after the start).
pub fn signal_fits(rec: &Recording, params: &Params) -> Result<Vec<(String, Fit)>, ReplayError> {
    let trace = crate::recording::replay(params, rec)?;
    let from = first_cost_sample(&rec.time);
    let mut out = Vec::new();
    for (name, _) in REPORT_SIGNALS {
        let Some(measured) = rec.column(name) else {
            continue;
        };
        if measured.iter().all(|&v| v == 0.0) {
            continue;
        }
        let model = trace.signal(name).expect("model output");
        out.push((
            name.to_string(),
            metrics::fit(&measured[from..], &model[from..]),
        ));
    }
    Ok(out)
}

/// Index of the first sample of the cost window.
fn first_cost_sample(time: &[f64]) -> usize {
    time.partition_point(|&t| t < time[0] + SKIP_START_S)
        .min(time.len().saturating_sub(2))
}

fn check_options(base: &Params, opts: &FitOptions) -> Result<(), FitError> {
    if opts.names.is_empty() {
        return Err(FitError::NoParameters);
    }
    if opts.names.len() != opts.bounds.len() {
        return Err(FitError::RangeCount {
            names: opts.names.len(),
            ranges: opts.bounds.len(),
        });
    }
    for (i, (name, &(lo, hi))) in opts.names.iter().zip(&opts.bounds).enumerate() {
        let var = by_name(name).filter(|v| v.causality == Causality::Parameter);
        let not_a_parameter = || FitError::NotAParameter(name.clone());
        let Some(Kind::Real { min, max, .. }) = var.map(|v| v.kind) else {
            return Err(not_a_parameter());
        };
        let unit = var.map_or("", |v| v.unit);
        if opts.names[..i].contains(name) {
            return Err(FitError::ListedTwice(name.clone()));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(FitError::EmptyRange {
                name: name.clone(),
                lo,
                hi,
                unit,
            });
        }
        if lo < min || hi > max {
            return Err(FitError::BeyondTable {
                name: name.clone(),
                lo,
                hi,
                min,
                max,
                unit,
            });
        }
        base.get(name).ok_or_else(not_a_parameter)?;
    }
    Ok(())
}

/// One measured signal of the cost with its weight sqrt(w_s).
struct Term {
    name: &'static str,
    measured: Vec<f64>,
    sqrt_weight: f64,
}

/// The closed-loop cost J of section 2.3 for a recording.
pub(crate) struct Objective {
    replay: Replay,
    base: Params,
    names: Vec<String>,
    terms: Vec<Term>,
    from: usize,
}

impl Objective {
    fn new(
        rec: &Recording,
        replay: Replay,
        base: Params,
        names: &[String],
    ) -> Result<Objective, FitError> {
        let from = first_cost_sample(&rec.time);
        let n = (rec.len() - from) as f64;
        let mut terms = Vec::new();
        for name in COST_SIGNALS {
            let Some(col) = rec.column(name) else {
                continue;
            };
            let measured = col[from..].to_vec();
            let range = measured.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
                - measured.iter().fold(f64::INFINITY, |a, &b| a.min(b));
            let sigma = noise_level(&measured).max(NOISE_FLOOR * range);
            if sigma > 0.0 {
                terms.push(Term {
                    name,
                    measured,
                    sqrt_weight: 1.0 / (sigma * n.sqrt()),
                });
            }
        }
        if terms.is_empty() {
            return Err(FitError::NothingToFit {
                file: rec.source.clone(),
            });
        }
        Ok(Objective {
            replay,
            base,
            names: names.to_vec(),
            terms,
            from,
        })
    }

    /// Number of residuals.
    pub fn len(&self) -> usize {
        self.terms.iter().map(|t| t.measured.len()).sum()
    }

    /// Weighted residuals sqrt(w_s) (measured - model), or None if the simulation failed.
    pub fn residuals(&self, values: &[f64]) -> Option<Vec<f64>> {
        let mut p = self.base.clone();
        for (name, &v) in self.names.iter().zip(values) {
            p.set(name, v).ok()?;
        }
        let trace = self.replay.run(&p);
        let mut r = Vec::with_capacity(self.len());
        for term in &self.terms {
            let model = trace.signal(term.name).expect("model output");
            r.extend(
                term.measured
                    .iter()
                    .zip(&model[self.from..])
                    .map(|(m, y)| term.sqrt_weight * (m - y)),
            );
        }
        r.iter().all(|v| v.is_finite()).then_some(r)
    }
}

/// The outcome of one optimiser, in unit coordinates.
#[derive(Clone, Debug)]
pub(crate) struct Outcome {
    pub best: Vec<f64>,
    pub cost: f64,
    pub history: Vec<f64>,
}

/// Evaluates candidates in parallel and counts simulations.
pub(crate) struct Evaluator<'a> {
    /// Weighted residual vector at physical parameter values, None if the simulation failed.
    objective: &'a (dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync),
    pub space: &'a [Bounds],
    simulations: AtomicUsize,
    progress: &'a Progress,
}

impl Evaluator<'_> {
    pub fn dim(&self) -> usize {
        self.space.len()
    }

    /// J at each candidate (in unit coordinates), +inf where the simulation failed. The order
    /// of the results is the order of the candidates whatever the thread scheduling.
    pub fn costs(&self, candidates: &[Vec<f64>]) -> Vec<f64> {
        self.residuals(candidates)
            .into_iter()
            .map(|r| r.map_or(f64::INFINITY, |r| r.iter().map(|v| v * v).sum()))
            .collect()
    }

    /// Weighted residual vectors at each candidate.
    pub fn residuals(&self, candidates: &[Vec<f64>]) -> Vec<Option<Vec<f64>>> {
        let out: Vec<Option<Vec<f64>>> = candidates
            .par_iter()
            .map(|u| (self.objective)(&bounds::to_phys(self.space, u)))
            .collect();
        self.simulations
            .fetch_add(candidates.len(), Ordering::Relaxed);
        self.progress.inc(candidates.len() as u64);
        out
    }

    pub fn report(&self, best: f64) {
        self.progress.best(best);
    }
}

/// A progress bar on stderr, drawn only when asked for and stderr is a terminal.
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    fn new(enabled: bool, budget: u64, label: &str) -> Progress {
        let bar = (enabled && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::with_draw_target(Some(budget), ProgressDrawTarget::stderr());
            let style = ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} simulations, {elapsed} {msg}",
            )
            .expect("valid template")
            .progress_chars("=> ");
            bar.set_style(style);
            bar.set_prefix(label.to_string());
            bar
        });
        Progress { bar }
    }

    fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
    }

    fn best(&self, cost: f64) {
        if let Some(b) = &self.bar {
            b.set_message(format!("best J = {cost:.4e}"));
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// The result of [`minimise`]: best values (physical units), J = sum of squared residuals,
/// the best J after each generation / iteration, and the number of evaluations.
#[derive(Clone, Debug)]
pub struct Minimum {
    pub values: Vec<f64>,
    pub cost: f64,
    pub history: Vec<f64>,
    pub evaluations: usize,
}

/// The default method (differential evolution, then Levenberg-Marquardt) on any weighted
/// residual vector: `residuals(values)` at physical values inside `bounds` (searched
/// log-scaled where the lower bound is positive), starting from `start`. Seeded and
/// reproducible: the same seed gives the same result on any number of threads.
pub fn minimise(
    residuals: &(dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync),
    bounds: &[(f64, f64)],
    start: &[f64],
    seed: u64,
) -> Minimum {
    let space: Vec<Bounds> = bounds
        .iter()
        .map(|&(lo, hi)| {
            if lo > 0.0 {
                Bounds::log(lo, hi)
            } else {
                Bounds::linear(lo, hi)
            }
        })
        .collect();
    let progress = Progress::new(false, 0, "calibrate");
    let eval = Evaluator {
        objective: residuals,
        space: &space,
        simulations: AtomicUsize::new(0),
        progress: &progress,
    };
    let global = de::run(&eval, &bounds::to_unit(&space, start), seed);
    let local = lm::minimize(&|u| eval.residuals(u), &global.best, &LOCAL);
    Minimum {
        values: bounds::to_phys(&space, &local.u),
        cost: local.cost,
        history: [global.history, local.history].concat(),
        evaluations: eval.simulations.load(Ordering::Relaxed),
    }
}
