//! The generic layer with a toy model: the paths the thrust model cannot be driven into on
//! purpose (a failed step, a panic inside the model).

use super::api;
use super::instance::Instance;
use super::log::LAYER_CATEGORIES;
use super::mode::Mode;
use super::model::{CoSimModel, Phase};
use super::types::*;
use serde::{Deserialize, Serialize};
use std::ffi::CString;
use std::ptr::{null, null_mut};

/// y' = u; a negative u makes the step fail, u = 42 makes the model panic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Toy {
    u: f64,
    y: f64,
}

impl CoSimModel for Toy {
    const GUID: &'static str = "{toy}";
    const LOG_CATEGORIES: &'static [&'static str] = LAYER_CATEGORIES;
    const MAX_STEP: f64 = 10.0;
    type Error = String;

    fn instantiate() -> Self {
        Toy { u: 0.0, y: 0.0 }
    }
    fn describe(vr: u32) -> Option<String> {
        ["`u`", "`y`"].get(vr as usize).map(|s| s.to_string())
    }
    fn get_reals(&self, vrs: &[u32], values: &mut [f64]) -> Result<(), String> {
        for (&vr, value) in vrs.iter().zip(values) {
            *value = [self.u, self.y]
                .get(vr as usize)
                .copied()
                .ok_or("unknown")?;
        }
        Ok(())
    }
    fn get_integer(&self, _: u32) -> Result<i32, String> {
        Err("no integers".into())
    }
    fn check_real(&self, vr: u32, _: f64, _: Phase) -> Result<(), String> {
        if vr == 0 {
            Ok(())
        } else {
            Err("only u can be set".into())
        }
    }
    fn set_real(&mut self, _: u32, value: f64) {
        self.u = value;
    }
    fn check_integer(&self, _: u32, _: i32, _: Phase) -> Result<(), String> {
        Err("no integers".into())
    }
    fn set_integer(&mut self, _: u32, _: i32) {}
    fn exit_initialization(&mut self, _: f64) -> Result<(), String> {
        Ok(())
    }
    fn do_step(&mut self, _: f64, h: f64) -> Result<(), String> {
        assert!(self.u != 42.0, "boom");
        if self.u < 0.0 {
            return Err("negative input.".into());
        }
        self.y += self.u * h;
        Ok(())
    }
}

struct Toyed(Fmi2Component);

impl Toyed {
    fn new() -> Self {
        let callbacks = Fmi2CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: null_mut(),
        };
        let (name, guid) = (
            CString::new("toy").unwrap(),
            CString::new(Toy::GUID).unwrap(),
        );
        let c = unsafe {
            api::instantiate::<Toy>(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                null(),
                &callbacks,
                1,
            )
        };
        assert!(!c.is_null());
        unsafe {
            assert_eq!(
                api::setup_experiment::<Toy>(c, 0, 0.0, 0, 0.0),
                Fmi2Status::Ok
            );
            assert_eq!(api::enter_initialization_mode::<Toy>(c), Fmi2Status::Ok);
            assert_eq!(api::exit_initialization_mode::<Toy>(c), Fmi2Status::Ok);
        }
        Toyed(c)
    }
    fn mode(&self) -> Mode {
        unsafe { Instance::<Toy>::from_component(self.0) }
            .unwrap()
            .mode
    }
    fn set_u(&self, u: f64) -> Fmi2Status {
        unsafe { api::set_real::<Toy>(self.0, [0].as_ptr(), 1, [u].as_ptr()) }
    }
    fn step(&self, t: f64) -> Fmi2Status {
        unsafe { api::do_step::<Toy>(self.0, t, 1.0) }
    }
    fn y(&self) -> f64 {
        let mut y = [0.0];
        assert_eq!(
            unsafe { api::get_real::<Toy>(self.0, [1].as_ptr(), 1, y.as_mut_ptr()) },
            Fmi2Status::Ok
        );
        y[0]
    }
}

impl Drop for Toyed {
    fn drop(&mut self) {
        unsafe { api::free_instance::<Toy>(self.0) }
    }
}

#[test]
fn a_failed_step_is_discarded_and_reported() {
    let toy = Toyed::new();
    toy.set_u(1.0);
    assert_eq!(toy.step(0.0), Fmi2Status::Ok);
    toy.set_u(-1.0);
    assert_eq!(toy.step(1.0), Fmi2Status::Discard);
    assert_eq!(toy.mode(), Mode::StepFailed);
    let (mut terminated, mut last) = (0, 0.0);
    unsafe {
        assert_eq!(
            api::get_boolean_status::<Toy>(toy.0, FMI2_TERMINATED, &mut terminated),
            Fmi2Status::Ok
        );
        assert_eq!(
            api::get_real_status::<Toy>(toy.0, FMI2_LAST_SUCCESSFUL_TIME, &mut last),
            Fmi2Status::Ok
        );
    }
    assert_eq!((terminated, last), (FMI2_TRUE, 1.0));
    assert_eq!(
        toy.step(1.0),
        Fmi2Status::Error,
        "no step after a discarded one"
    );
    assert_eq!(toy.y(), 1.0);
    assert_eq!(unsafe { api::terminate::<Toy>(toy.0) }, Fmi2Status::Ok);
}

#[test]
fn a_panic_is_caught_and_a_saved_state_recovers() {
    let toy = Toyed::new();
    toy.set_u(2.0);
    let mut saved = null_mut();
    assert_eq!(
        unsafe { api::get_fmu_state::<Toy>(toy.0, &mut saved) },
        Fmi2Status::Ok
    );
    toy.set_u(42.0);
    assert_eq!(toy.step(0.0), Fmi2Status::Error);
    assert_eq!(toy.mode(), Mode::Error);
    assert_eq!(toy.y(), 0.0, "getters still work in the Error mode");
    assert_eq!(
        toy.step(0.0),
        Fmi2Status::Error,
        "no step in the Error mode"
    );
    assert_eq!(
        unsafe { api::set_fmu_state::<Toy>(toy.0, saved) },
        Fmi2Status::Ok
    );
    assert_eq!(toy.mode(), Mode::StepComplete);
    assert_eq!(toy.step(0.0), Fmi2Status::Ok);
    assert_eq!(toy.y(), 2.0);
}

#[test]
fn refused_calls_change_nothing() {
    let toy = Toyed::new();
    assert_eq!(
        unsafe { api::set_real::<Toy>(toy.0, [0, 1].as_ptr(), 2, [5.0, 1.0].as_ptr()) },
        Fmi2Status::Error
    );
    assert_eq!(toy.step(0.0), Fmi2Status::Ok);
    assert_eq!(toy.y(), 0.0, "u was not set by the refused call");
    assert_eq!(toy.step(3.0), Fmi2Status::Error);
    assert_eq!(toy.mode(), Mode::StepComplete);
    assert_eq!(toy.step(1.0), Fmi2Status::Ok);
}
