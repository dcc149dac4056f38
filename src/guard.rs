//! Panic containment: a third-party decoder fed a corrupt file may panic;
//! [`guarded`] turns that into an error for the file concerned.

/// Number of [`guarded`] regions running (in any thread: a decoder's own
/// worker threads panic too, and their messages must not reach the user).
static QUIET_PANICS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A panic caught by [`guarded`]; it displays as the panic's message
/// (`internal panic` when the payload was not text).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct Panicked {
    /// The panic's message.
    pub message: String,
}

/// Runs `f`, turning a panic inside it (e.g. in a third-party decoder fed a
/// corrupt file) into [`Panicked`]; panic messages are not printed while
/// a guarded region runs. Panics outside still print as usual.
pub fn guarded<T>(f: impl FnOnce() -> T) -> std::result::Result<T, Panicked> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET_PANICS.load(std::sync::atomic::Ordering::SeqCst) == 0 {
                prev(info)
            }
        }));
    });
    QUIET_PANICS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET_PANICS.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
    r.map_err(|e| Panicked {
        message: e
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "internal panic".into()),
    })
}
