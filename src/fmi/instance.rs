//! One FMU instance (the `fmi2Component`): the model, the mode, the communication clock,
//! the logger and the FMU states handed out. No global state: every instance is a separate
//! heap object, so several instances can live in one process and each can be used from any
//! thread (one thread at a time per instance, as FMI requires).

use super::log::{self, Logger};
use super::mode::Mode;
use super::model::{CoSimModel, Phase};
use super::types::{Fmi2Component, Fmi2FmuState, Fmi2Status};
use serde::{Deserialize, Serialize};
use std::any::Any;
use std::collections::HashSet;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Marks a live instance; cleared when it is freed (best-effort check of the component).
const MAGIC: u64 = 0x464d_4932_5253_4354;

/// Relative and absolute tolerance on `currentCommunicationPoint` and the stop time:
/// |t - t_expected| <= COMMUNICATION_TOLERANCE * max(1, |t_expected|).
pub const COMMUNICATION_TOLERANCE: f64 = 1e-9;

pub fn time_tolerance(t: f64) -> f64 {
    COMMUNICATION_TOLERANCE * t.abs().max(1.0)
}

/// Time bookkeeping of the co-simulation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    pub start_time: f64,
    pub stop_time: Option<f64>,
    /// The last communication point reached; the next fmi2DoStep must start here.
    pub time: f64,
    /// The slave asked to end the simulation (fmi2GetBooleanStatus(fmi2Terminated)).
    pub terminated: bool,
}

/// Everything fmi2GetFMUstate saves and fmi2SetFMUstate restores (not the logger, name or
/// resource location).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "M: CoSimModel")]
pub struct Snapshot<M> {
    pub mode: Mode,
    pub clock: Clock,
    pub model: M,
}

/// Why a call did not return fmi2OK.
#[derive(Debug)]
pub enum Problem {
    /// fmi2Error; the call was refused before it changed anything, so the instance stays
    /// in its mode and is usable.
    Reject(String),
    /// fmi2Discard; the callee has set the mode.
    Discard(String),
}

pub type Outcome = Result<(), Problem>;

/// Refuses the call; `why` becomes the one line logged to the importer.
pub fn reject<T>(why: impl std::fmt::Display) -> Result<T, Problem> {
    Err(Problem::Reject(why.to_string()))
}

pub struct Instance<M: CoSimModel> {
    magic: u64,
    pub log: Logger,
    pub resource_location: Option<String>,
    pub mode: Mode,
    pub clock: Clock,
    pub model: M,
    /// The FMU states this instance handed out and has not freed.
    states: HashSet<usize>,
}

impl<M: CoSimModel> Instance<M> {
    pub fn new(log: Logger, resource_location: Option<String>) -> Box<Self> {
        Box::new(Instance {
            magic: MAGIC,
            log,
            resource_location,
            mode: Mode::Instantiated,
            clock: Clock::default(),
            model: M::instantiate(),
            states: HashSet::new(),
        })
    }

    /// The instance behind a component pointer, if it is one.
    ///
    /// # Safety
    /// `c` is NULL or a pointer returned by fmi2Instantiate of this library.
    pub unsafe fn from_component<'a>(c: Fmi2Component) -> Option<&'a mut Self> {
        let instance = (c as *mut Self).as_mut()?;
        (instance.magic == MAGIC).then_some(instance)
    }

    /// Frees the instance and every FMU state it still owns.
    ///
    /// # Safety
    /// `c` was returned by fmi2Instantiate of this library and is not used afterwards.
    pub unsafe fn free(c: Fmi2Component) {
        if Self::from_component(c).is_none() {
            return;
        }
        let mut instance = Box::from_raw(c as *mut Self);
        for state in instance.states.drain() {
            drop(Box::from_raw(state as *mut Snapshot<M>));
        }
        instance.magic = 0;
    }

    pub fn phase(&self) -> Phase {
        match self.mode {
            Mode::Instantiated => Phase::Instantiated,
            Mode::InitializationMode => Phase::Initialization,
            _ => Phase::Stepping,
        }
    }

    pub fn event(&self, message: &str) {
        self.log.log(Fmi2Status::Ok, log::EVENTS, message);
    }

    /// Runs one FMI call: checks the mode against `mask`, runs `body` with panics caught,
    /// maps any problem to the returned status and then logs the call once, with the status
    /// it returned:
    /// - fmi2OK: `fmi2DoStep(args) -> fmi2OK` under `logCalls` (if on);
    /// - otherwise one line at the real status under its category (`logStatusError`, ...):
    ///   `fmi2DoStep: why.`, followed by ` Call: fmi2DoStep(args) -> fmi2Error.` when
    ///   `logCalls` is on. If the status category is switched off but `logCalls` is on, the
    ///   same line goes under `logCalls` (still with the real status).
    ///
    /// A panic moves the instance to the Error mode (its model may be inconsistent).
    pub fn call(
        &mut self,
        function: &str,
        mask: u32,
        args: impl FnOnce() -> String,
        body: impl FnOnce(&mut Self) -> Outcome,
    ) -> Fmi2Status {
        let (status, problem) = self.run(mask, body);
        let calls_on = self.log.enabled(log::CALLS);
        let call = || format!("{function}({}) -> {}", args(), status_name(status));
        match problem {
            None => {
                if calls_on {
                    self.log.log(status, log::CALLS, &call());
                }
            }
            Some(message) => {
                let category = log::status_category(status);
                let text = if calls_on {
                    format!("{function}: {message} Call: {}.", call())
                } else {
                    format!("{function}: {message}")
                };
                if self.log.enabled(category) {
                    self.log.log(status, category, &text);
                } else if calls_on {
                    self.log.log(status, log::CALLS, &text);
                }
            }
        }
        status
    }

    /// The mode check and the body of [`Instance::call`]: the status and, unless it is
    /// fmi2OK, why.
    fn run(
        &mut self,
        mask: u32,
        body: impl FnOnce(&mut Self) -> Outcome,
    ) -> (Fmi2Status, Option<String>) {
        if !self.mode.allowed(mask) {
            let allowed = Mode::describe_mask(mask);
            let message = format!(
                "Illegal call sequence: not allowed in mode {:?} (allowed in: {allowed}).",
                self.mode
            );
            return (Fmi2Status::Error, Some(message));
        }
        match catch_unwind(AssertUnwindSafe(|| body(&mut *self))) {
            Ok(Ok(())) => (Fmi2Status::Ok, None),
            Ok(Err(Problem::Reject(message))) => (Fmi2Status::Error, Some(message)),
            Ok(Err(Problem::Discard(message))) => (Fmi2Status::Discard, Some(message)),
            Err(payload) => {
                self.mode = Mode::Error;
                let detail = panic_message(payload.as_ref());
                let message = format!("internal error ({detail}); only getters, fmi2SetFMUstate, fmi2Reset and fmi2FreeInstance are allowed now.");
                (Fmi2Status::Error, Some(message))
            }
        }
    }

    pub fn snapshot(&self) -> Snapshot<M> {
        Snapshot {
            mode: self.mode,
            clock: self.clock,
            model: self.model.clone(),
        }
    }

    pub fn restore(&mut self, snapshot: &Snapshot<M>) {
        self.mode = snapshot.mode;
        self.clock = snapshot.clock;
        self.model = snapshot.model.clone();
    }

    /// Hands out a new FMU state holding `snapshot`.
    pub fn adopt_state(&mut self, snapshot: Snapshot<M>) -> Fmi2FmuState {
        let state = Box::into_raw(Box::new(snapshot));
        self.states.insert(state as usize);
        state.cast()
    }

    /// The FMU state behind `state`, if this instance handed it out and has not freed it.
    pub fn state_mut(&mut self, state: Fmi2FmuState) -> Result<&mut Snapshot<M>, Problem> {
        if state.is_null() {
            return reject("the FMU state is NULL.");
        }
        if !self.states.contains(&(state as usize)) {
            return reject("the FMU state was not created by this instance or has been freed.");
        }
        // SAFETY: registered pointers come from Box::into_raw in adopt_state and are live.
        Ok(unsafe { &mut *(state as *mut Snapshot<M>) })
    }

    /// Frees an FMU state this instance handed out.
    pub fn release_state(&mut self, state: Fmi2FmuState) -> Outcome {
        self.state_mut(state)?;
        self.states.remove(&(state as usize));
        // SAFETY: checked just above that it is a live state from adopt_state.
        drop(unsafe { Box::from_raw(state as *mut Snapshot<M>) });
        Ok(())
    }
}

/// The C name of a status, as it appears in the call log.
pub fn status_name(status: Fmi2Status) -> &'static str {
    match status {
        Fmi2Status::Ok => "fmi2OK",
        Fmi2Status::Warning => "fmi2Warning",
        Fmi2Status::Discard => "fmi2Discard",
        Fmi2Status::Error => "fmi2Error",
        Fmi2Status::Fatal => "fmi2Fatal",
        Fmi2Status::Pending => "fmi2Pending",
    }
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic".to_string()
    }
}
