//! The exact event-driven engine (placeholder while the foundation lands).

/// A simulation that cannot be carried out as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The request is outside what the engine can compute.
    #[error("{0}")]
    Unsupported(String),
}
