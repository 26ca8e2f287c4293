//! Shared by the FMI integration tests (each uses a part of it): the FMI 2 C types and the
//! loader of the packaged FMU.
#![allow(dead_code)]

pub mod fmi2;
