//! Limits on every size that comes from the input, checked before the memory or time that the size
//! implies is spent. Each is far above what a real budget needs; a file beyond one is refused with
//! a located error ([`crate::UncertaintyError::TooLarge`] or a [`crate::BudgetFileError`]).
//!
//! Everything else is linear in the input size: nested budgets are evaluated and flattened once
//! each however often they are referred to, correlations are checked and combined through their
//! envelope (work proportional to the envelope, not to rows³), and names are looked up through
//! hash maps.

/// Largest budget or instrument file, in bytes (16 MiB; real files are a few kB). The parse is
/// linear in the file size, so this also bounds the memory of the parse.
pub const MAX_FILE_BYTES: usize = 16 << 20;

/// Most budgets in one file.
pub const MAX_BUDGETS: usize = 10_000;

/// Most rows (contributions) in one budget.
pub const MAX_ROWS: usize = 100_000;

/// Most correlations listed in one budget.
pub const MAX_CORRELATIONS: usize = 1_000_000;

/// Most observations in one `observations = [...]` row.
pub const MAX_OBSERVATIONS: usize = 1_000_000;

/// Most stored entries of the correlation matrix's envelope (profile): row i of the correlated
/// rows holds the entries from its first correlated row up to itself. The positive-semi-definite
/// check and the correlated Monte Carlo draw cost at most this much per row, so a chain of
/// correlations between neighbouring rows (envelope ≈ 2 per row) is cheap whatever its length,
/// while a dense 2,000-row correlation matrix (2 million entries) is the largest accepted.
pub const MAX_CORRELATION_ENVELOPE: usize = 2_000_000;

/// Most leaf coefficients and correlation terms held or summed to combine budgets that share
/// nested budgets exactly (see `budget::shared`): 10⁷, about 160 MB at most. A budget referred to
/// by several rows makes every budget above it carry the coefficients of its leaves.
pub const MAX_SHARED_ENTRIES: usize = 10_000_000;

/// Most Monte Carlo work in one run, in draws and correlation products: trials × (inputs +
/// off-diagonal envelope entries). 2·10⁹ is about 10–30 s on one core; 10,000 inputs allow
/// 200,000 trials.
pub const MAX_MC_DRAWS: u64 = 2_000_000_000;

/// Most values held at once in the Monte Carlo draw buffer (inputs × trials per chunk): 4 Mi
/// values, 32 MiB. Models with up to 256 inputs are drawn 16,384 trials at a time; larger ones in
/// smaller chunks.
pub const MAX_MC_BUFFER: usize = 1 << 22;

/// Longest error message of a budget or instrument file, in characters; any echoed input beyond
/// it is cut (names are already shortened by [`crate::short`]).
pub const MAX_MESSAGE_CHARS: usize = 300;
