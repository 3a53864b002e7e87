//! World files for a front end: several checked as a run would check them, a line said
//! for each ([`check`]).

use std::path::PathBuf;

use crate::{Progress, ReportError};

/// Checks each world file (or shipped world's name) of `files` as a run would: a line
/// said for each valid one, a notice with the error for each other; an error counting
/// the invalid ones when there are any.
pub fn check(files: &[PathBuf], progress: &dyn Progress) -> Result<(), ReportError> {
    let mut bad = 0;
    for f in files {
        match mmq_lab::runner::check_world(f) {
            Ok(w) => progress.say(&format!("{}\n", crate::terminal::world_ok(f, &w))),
            Err(e) => {
                progress.notice(&format!("error: {e}"));
                bad += 1;
            }
        }
    }
    match bad {
        0 => Ok(()),
        bad => Err(ReportError::InvalidWorlds { bad, total: files.len() }),
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;

    #[derive(Default)]
    struct Told(Mutex<Vec<String>>);

    impl Progress for Told {
        fn notice(&self, text: &str) {
            self.0.lock().unwrap().push(text.to_string());
        }
        fn say(&self, text: &str) {
            self.0.lock().unwrap().push(text.to_string());
        }
    }

    #[test]
    fn each_file_gets_a_line_and_the_invalid_ones_are_counted() {
        let told = Told::default();
        let files = [PathBuf::from("paper-5x5"), PathBuf::from("/no/such/world.toml")];
        let e = check(&files, &told).unwrap_err();
        assert_eq!(e.to_string(), "1 of 2 world files are invalid");
        assert!(e.is_input_error());
        let told = told.0.into_inner().unwrap();
        assert!(told[0].ends_with('\n') && told[1].starts_with("error: /no/such/world.toml"), "{told:?}");
        assert!(check(&files[..1], &Told::default()).is_ok());
    }
}
