//! Messages to the importer's logger callback.
//!
//! - The callback is always called with the format `"%s"` and the message as its single
//!   variadic argument, so a `%` in a message (or in a value reference's name) is never
//!   interpreted. A NULL logger is accepted and then nothing is logged.
//! - Every message has a category from the modelDescription's `<LogCategories>`:
//!   `logStatusWarning` / `logStatusDiscard` / `logStatusError` / `logStatusFatal` by status,
//!   `logEvents` for life-cycle events, `logCalls` for every call with its arguments.
//! - With `loggingOn = fmi2True` every category is on; with `fmi2False` only
//!   `logStatusError` and `logStatusFatal` are (an error nobody hears about is worse than a
//!   noisy log). fmi2SetDebugLogging with a list of categories switches exactly those,
//!   including the error categories, and rejects an unknown name.

use super::types::{Fmi2CallbackLogger, Fmi2ComponentEnvironment, Fmi2Status};
use std::ffi::{c_int, CString};

pub const EVENTS: &str = "logEvents";
pub const CALLS: &str = "logCalls";
/// The categories the layer itself logs to; a model's table must declare all of them.
pub const LAYER_CATEGORIES: &[&str] = &[
    EVENTS,
    CALLS,
    "logStatusWarning",
    "logStatusDiscard",
    "logStatusError",
    "logStatusFatal",
];
const ALWAYS_ON: &[&str] = &["logStatusError", "logStatusFatal"];

/// The category of a message with status `status`.
pub fn status_category(status: Fmi2Status) -> &'static str {
    match status {
        Fmi2Status::Warning => "logStatusWarning",
        Fmi2Status::Discard => "logStatusDiscard",
        Fmi2Status::Error => "logStatusError",
        Fmi2Status::Fatal => "logStatusFatal",
        Fmi2Status::Ok | Fmi2Status::Pending => EVENTS,
    }
}

/// The importer's logger of one instance with its category switches.
/// fmi2SetDebugLogging named a category the FMU does not have.
#[derive(Debug)]
pub struct UnknownCategory {
    name: String,
    categories: &'static [&'static str],
}

impl std::fmt::Display for UnknownCategory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "unknown log category \"{}\"; the categories are {}",
            self.name,
            self.categories.join(", ")
        )
    }
}

impl std::error::Error for UnknownCategory {}

pub struct Logger {
    callback: Fmi2CallbackLogger,
    environment: Fmi2ComponentEnvironment,
    instance_name: CString,
    categories: &'static [&'static str],
    enabled: Vec<bool>,
}

impl Logger {
    pub fn new(
        callback: Fmi2CallbackLogger,
        environment: Fmi2ComponentEnvironment,
        instance_name: &str,
        categories: &'static [&'static str],
        logging_on: bool,
    ) -> Self {
        let mut logger = Logger {
            callback,
            environment,
            instance_name: c_string(instance_name),
            categories,
            enabled: vec![false; categories.len()],
        };
        logger.switch_all(logging_on);
        logger
    }

    /// fmi2SetDebugLogging with no category list: every category on or off (errors stay on).
    pub fn switch_all(&mut self, on: bool) {
        for (enabled, name) in self.enabled.iter_mut().zip(self.categories) {
            *enabled = on || ALWAYS_ON.contains(name);
        }
    }

    /// fmi2SetDebugLogging with a list: switches exactly the named categories, or none if
    /// one name is unknown.
    pub fn switch(&mut self, on: bool, names: &[String]) -> Result<(), UnknownCategory> {
        let mut indices = Vec::with_capacity(names.len());
        for name in names {
            let index = self
                .categories
                .iter()
                .position(|c| c == name)
                .ok_or_else(|| UnknownCategory {
                    name: name.clone(),
                    categories: self.categories,
                })?;
            indices.push(index);
        }
        for index in indices {
            self.enabled[index] = on;
        }
        Ok(())
    }

    pub fn enabled(&self, category: &str) -> bool {
        self.categories
            .iter()
            .position(|c| *c == category)
            .is_some_and(|i| self.enabled[i])
    }

    /// Sends `message` if its category is on.
    pub fn log(&self, status: Fmi2Status, category: &str, message: &str) {
        if !self.enabled(category) {
            return;
        }
        let Some(callback) = self.callback else {
            return;
        };
        let category = c_string(category);
        let text = c_string(message);
        // SAFETY: the importer's logger, called as fmi2CallbackLogger with "%s" and one string.
        unsafe {
            callback(
                self.environment,
                self.instance_name.as_ptr(),
                status as c_int,
                category.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            );
        }
    }
}

/// A C string; an interior NUL (which C would cut the message at) is written as `\0`.
fn c_string(s: &str) -> CString {
    CString::new(s.replace('\0', "\\0")).expect("no interior NUL after replacement")
}

#[cfg(test)]
mod tests {
    use super::*;

    const CATS: &[&str] = LAYER_CATEGORIES;

    #[test]
    fn errors_stay_on_unless_switched_off_by_name() {
        let mut l = Logger::new(None, std::ptr::null_mut(), "a", CATS, false);
        assert!(l.enabled("logStatusError") && !l.enabled(EVENTS) && !l.enabled(CALLS));
        l.switch_all(true);
        assert!(l.enabled(EVENTS) && l.enabled(CALLS));
        l.switch(false, &["logStatusError".into()]).unwrap();
        assert!(!l.enabled("logStatusError") && l.enabled(EVENTS));
        let err = l
            .switch(true, &["logEvents".into(), "nope".into()])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("\"nope\"") && err.contains("logCalls"),
            "{err}"
        );
        assert!(
            !l.enabled("logStatusError"),
            "nothing switched when one name is unknown"
        );
        assert!(!l.enabled("undeclared"));
    }

    #[test]
    fn interior_nul_is_escaped() {
        assert_eq!(c_string("a\0b").to_str().unwrap(), "a\\0b");
    }
}
