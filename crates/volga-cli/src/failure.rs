//! How a subcommand fails: a message and the exit code it maps to (1: the run or a
//! required check failed, 2: bad input).

pub struct Failure {
    pub code: u8,
    pub message: String,
}

/// Bad input: exit code 2.
pub fn bad_input(message: impl Into<String>) -> Failure {
    Failure {
        code: 2,
        message: message.into(),
    }
}

/// The run failed (an output could not be written, a requirement does not hold): exit 1.
pub fn failed(message: impl Into<String>) -> Failure {
    Failure {
        code: 1,
        message: message.into(),
    }
}
