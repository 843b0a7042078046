//! What Ctrl-C (SIGINT) says before the program stops: each command sets a note saying what has
//! been kept and how to continue. Results are written atomically, so stopping at any moment leaves
//! only finished files behind.

use std::sync::Mutex;

type Note = Box<dyn Fn() -> String + Send>;

static NOTE: Mutex<Option<Note>> = Mutex::new(None);

/// Installs the handler (once, at start-up). Exit status 130, as shells report SIGINT.
pub fn install() {
    let _ = ctrlc::set_handler(|| {
        let note = NOTE
            .lock()
            .ok()
            .and_then(|n| n.as_ref().map(|f| f()))
            .unwrap_or_else(|| "interrupted".into());
        eprintln!("\n{note}");
        std::process::exit(130);
    });
}

/// Sets what an interruption from now on reports.
pub fn on_interrupt(note: impl Fn() -> String + Send + 'static) {
    if let Ok(mut n) = NOTE.lock() {
        *n = Some(Box::new(note));
    }
}
