//! The debugger's errors, by kind: what the page shows a user (the kind's
//! words beside the message) and what the command line prints.

/// Any error with its context, as the debugger's sources report them.
pub type Source = Box<dyn std::error::Error + Send + Sync + 'static>;

/// What went wrong in the debugger.
#[derive(Debug, thiserror::Error)]
pub enum VizError {
    /// A request the current state cannot serve: a pair or a phase that is
    /// not there, a demonstration that cannot be saved yet, an unknown
    /// records file or seed.
    #[error("{0}")]
    Request(String),
    /// Models, demonstrations, records or scene files that cannot be read,
    /// or that differ from the ones a record was made with.
    #[error("{}{}", prefix(.context), .source)]
    Files { context: String, source: Source },
    /// A decision or an action that failed (the decider's or the world's
    /// error).
    #[error("{}{}", prefix(.context), .source)]
    Decide { context: String, source: Source },
    /// A rerun recording that cannot be written.
    #[error("{}{}", prefix(.context), .source)]
    Recording { context: String, source: Source },
}

/// `context: `, or nothing for an error of a crate below taken as it is.
fn prefix(context: &str) -> String {
    if context.is_empty() {
        String::new()
    } else {
        format!("{context}: ")
    }
}

/// The kinds of [`VizError`], as the page names them.
impl VizError {
    /// A short name of the kind, for the page (`request`, `files`, `decide`,
    /// `recording`).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Request(_) => "request",
            Self::Files { .. } => "files",
            Self::Decide { .. } => "decide",
            Self::Recording { .. } => "recording",
        }
    }

    /// The innermost error of the chain (this one when it has no source).
    pub fn root_cause(&self) -> &(dyn std::error::Error + 'static) {
        let mut e: &(dyn std::error::Error + 'static) = self;
        while let Some(s) = e.source() {
            e = s;
        }
        e
    }

    /// A request refused with `message`.
    pub fn request(message: impl Into<String>) -> Self {
        Self::Request(message.into())
    }

    /// This error with `context` before it, of the same kind.
    pub fn within(self, context: impl Into<String>) -> Self {
        let context = context.into();
        match self {
            Self::Request(m) => Self::Request(join(&context, &m)),
            Self::Files { context: c, source } => Self::Files {
                context: join(&context, &c),
                source,
            },
            Self::Decide { context: c, source } => Self::Decide {
                context: join(&context, &c),
                source,
            },
            Self::Recording { context: c, source } => Self::Recording {
                context: join(&context, &c),
                source,
            },
        }
    }
}

/// `outer: inner`, either of which may be empty.
fn join(outer: &str, inner: &str) -> String {
    match (outer.is_empty(), inner.is_empty()) {
        (_, true) => outer.to_owned(),
        (true, false) => inner.to_owned(),
        (false, false) => format!("{outer}: {inner}"),
    }
}

/// `Result` with [`VizError`].
pub type Result<T, E = VizError> = std::result::Result<T, E>;

/// An error of any crate under a context, as the kind the method names
/// (`files` for reading models, demonstrations and records, `deciding` for
/// a decision or an action, `recording` for rerun); a [`VizError`] keeps its
/// own kind and gets the context.
pub trait Context<T> {
    fn files(self, context: impl FnOnce() -> String) -> Result<T>;
    fn deciding(self, context: impl FnOnce() -> String) -> Result<T>;
    fn recording(self, context: impl FnOnce() -> String) -> Result<T>;
}

impl<T, E: Into<Source>> Context<T> for std::result::Result<T, E> {
    fn files(self, context: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| {
            wrap(e.into(), context(), |context, source| VizError::Files {
                context,
                source,
            })
        })
    }

    fn deciding(self, context: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| {
            wrap(e.into(), context(), |context, source| VizError::Decide {
                context,
                source,
            })
        })
    }

    fn recording(self, context: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| {
            wrap(e.into(), context(), |context, source| VizError::Recording {
                context,
                source,
            })
        })
    }
}

/// `source` under `context`: a [`VizError`] keeps its kind, anything else
/// takes the kind `make` gives.
fn wrap(source: Source, context: String, make: fn(String, Source) -> VizError) -> VizError {
    match source.downcast::<VizError>() {
        Ok(v) => v.within(context),
        Err(other) => make(context, other),
    }
}

/// An option that must hold a value: `None` is a refused request.
pub trait Required<T> {
    fn required(self, message: impl FnOnce() -> String) -> Result<T>;
}

impl<T> Required<T> for Option<T> {
    fn required(self, message: impl FnOnce() -> String) -> Result<T> {
        self.ok_or_else(|| VizError::Request(message()))
    }
}

/// Refuses a request: `return Err(VizError::Request(format!(...)))`.
#[macro_export]
macro_rules! refuse {
    ($($arg:tt)*) => {
        return Err($crate::error::VizError::Request(format!($($arg)*)))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_keeps_a_kind_and_gives_one_to_other_errors() {
        let io: std::result::Result<(), std::io::Error> = Err(std::io::Error::other("gone"));
        let e = io
            .files(|| "reading models/stack.safetensors".into())
            .expect_err("err");
        assert_eq!(e.kind(), "files");
        assert_eq!(e.to_string(), "reading models/stack.safetensors: gone");
        let inner: Result<()> = Err(VizError::request("no pair 9"));
        let e = inner.deciding(|| "query".into()).expect_err("err");
        assert_eq!(e.kind(), "request", "a request stays a request");
        assert_eq!(e.to_string(), "query: no pair 9");
        let none: Option<u8> = None;
        assert_eq!(
            none.required(|| "nothing".into()).expect_err("err").kind(),
            "request"
        );
    }
}

/// The errors of the crates below, each as the kind it is to the debugger
/// (their messages as they are; the literal says where they come from).
macro_rules! from_errors {
    ($($t:ty => $kind:ident, $context:literal;)+) => {$(
        impl From<$t> for VizError {
            fn from(e: $t) -> Self {
                from_errors!(@make $kind, $context, e)
            }
        }
    )+};
    (@make Request, $context:literal, $e:expr) => {
        VizError::Request($e.to_string())
    };
    (@make $kind:ident, $context:literal, $e:expr) => {
        VizError::$kind {
            context: String::new(),
            source: Box::new($e),
        }
    };
}

/// A decider's error (any error, boxed) is a failed decision.
impl From<seespot_sim::ActorError> for VizError {
    fn from(e: seespot_sim::ActorError) -> Self {
        wrap(e, "deciding".to_owned(), |context, source| {
            VizError::Decide { context, source }
        })
    }
}

from_errors! {
    std::io::Error => Files, "input or output";
    seespot_sim::DemoError => Files, "demonstration";
    seespot_sim::custom::DemonstrateError => Request, "demonstration";
    seespot_sim::seeds::SeedError => Request, "seed";
    seespot_policy::PolicyError => Files, "policy";
    seespot_ssr::SsrError => Files, "See-SPOT-Run";
    seespot_eval::EvalError => Files, "evaluation";
    seespot_eval::records::RecordError => Files, "records";
    tokio::task::JoinError => Decide, "a background task";
}
