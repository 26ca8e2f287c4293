//! Why a recording cannot be diagnosed (bad input: the command prints it in one line).

use tbm_thrust::params::ParamError;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{samples} samples: the diagnosis needs at least {min}")]
    TooFewSamples { samples: usize, min: usize },
    #[error("missing required column `{0}`")]
    MissingColumn(&'static str),
    /// An error of the recording named `source`.
    #[error("{source_name}: {error}")]
    Recording {
        source_name: String,
        error: Box<Error>,
    },
    #[error(transparent)]
    Params(#[from] ParamError),
}
