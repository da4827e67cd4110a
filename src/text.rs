//! Words for the user: what a failed file operation means and what to do, how a failed command
//! ends, and counts with the right noun ("1 frame", "2 frames").

/// What went wrong with a file operation, and what to do about it: a full disk and a refused
/// permission call for different fixes.
pub fn io_reason(e: &std::io::Error) -> String {
    use std::io::ErrorKind;
    let fix = match e.kind() {
        ErrorKind::StorageFull => "free some space, or choose a directory on another disk",
        ErrorKind::PermissionDenied => "the directory is not writable by you: choose one that is",
        ErrorKind::ReadOnlyFilesystem => "the file system is read-only: choose a directory on a writable one",
        ErrorKind::NotFound => "a folder on the path does not exist: create it, or check the path",
        ErrorKind::NotADirectory => "a part of the path is a file, not a directory",
        ErrorKind::AlreadyExists => "a file of that name is in the way",
        _ => return e.to_string(),
    };
    format!("{e}; {fix}")
}

/// `singular` for one, `plural` otherwise: "1 frame", "2 frames".
pub fn plural<'a>(n: impl TryInto<u64>, singular: &'a str, plural: &'a str) -> &'a str {
    if n.try_into().ok() == Some(1) {
        singular
    } else {
        plural
    }
}

/// A count and its noun: `count(1, "frame", "frames")` is "1 frame".
pub fn count(n: impl TryInto<u64> + std::fmt::Display + Copy, singular: &str, plural_: &str) -> String {
    format!("{n} {}", plural(n, singular, plural_))
}

/// How a command of `mpm` (or a bench binary) ends: an error is printed once as `error: ...` with its
/// causes, never as the `Error: ...` debug dump a `main` returning `Result` would print.
pub fn exit_code(result: anyhow::Result<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // `mpm run | head`: the reader has all it wanted; stop quietly, as other tools do.
        Err(e) if is_broken_pipe(&e) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .filter_map(|cause| cause.downcast_ref::<std::io::Error>())
        .any(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}
