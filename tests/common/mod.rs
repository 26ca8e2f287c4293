//! Shared by the FMI integration tests (each test file uses a part of it).
#![allow(dead_code)]

pub mod fmi2;
