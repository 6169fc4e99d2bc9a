//! Kernel errors as Python exceptions: `ValueError` for bad input, `MemoryError` for an
//! allocation refused before it happens, `OSError` for files. Messages are the CLI's.

use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::PyErr;
use volga_core::memory::Bytes;
use volga_scene::{BuildError, SceneError};

pub fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

pub fn os_error(message: impl Into<String>) -> PyErr {
    PyOSError::new_err(message.into())
}

/// `MemoryError` naming what needed the memory, the size and the limit.
pub fn memory_error(what: &str, needed: u64, limit: u64) -> PyErr {
    PyMemoryError::new_err(format!(
        "{what} needs an estimated {}, more than the {} available (pass memory_limit= to allow it)",
        Bytes(needed as u128),
        Bytes(limit as u128)
    ))
}

/// Refuses `needed` bytes over `limit` (the caller's `memory_limit`, else the machine's
/// available memory).
pub fn check_memory(what: &str, needed: u64, limit: Option<u64>) -> Result<(), PyErr> {
    match limit {
        Some(limit) if needed > limit => Err(PyMemoryError::new_err(format!(
            "{what} needs an estimated {}, more than memory_limit={limit} ({})",
            Bytes(needed as u128),
            Bytes(limit as u128)
        ))),
        Some(_) => Ok(()),
        None => {
            let available = volga_core::memory::available_bytes().unwrap_or(u64::MAX);
            if needed > available {
                return Err(memory_error(what, needed, available));
            }
            Ok(())
        }
    }
}

pub fn mesh_error(e: volga_mesh::MeshError) -> PyErr {
    match e {
        volga_mesh::MeshError::Io { .. } => os_error(e.to_string()),
        _ => value_error(e.to_string()),
    }
}

pub fn scene_error(e: SceneError) -> PyErr {
    match e {
        SceneError::Read { .. } => os_error(e.to_string()),
        SceneError::TooLarge { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
        _ => value_error(e.to_string()),
    }
}

pub fn build_error(e: BuildError) -> PyErr {
    match e {
        BuildError::Scene(s) => scene_error(s),
        BuildError::Io(io) => os_error(io.to_string()),
        BuildError::Render { .. } => pyo3::exceptions::PyRuntimeError::new_err(e.to_string()),
        BuildError::Limit { .. } => pyo3::exceptions::PyMemoryError::new_err(e.to_string()),
    }
}

pub fn io_error(e: volga_io::IoError) -> PyErr {
    match e {
        volga_io::IoError::Format { .. } => value_error(e.to_string()),
        _ => os_error(e.to_string()),
    }
}
