//! Memory a command is about to ask for, checked before it asks: an allocation that fails aborts
//! the process (no `error:` line, exit 134), so a command that sizes its work by a flag
//! (`detect --threads`: one detector a thread) first measures one unit of it and reserves the
//! whole address space it will need, refusing with a message when the system (an address-space
//! limit, `ulimit -v`) will not give it.
//!
//! Linux only (the address space from `/proc/self/statm`); elsewhere nothing is checked.

/// The address space of this process, bytes (`/proc/self/statm`'s first field).
fn mapped_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().next()?.parse().ok()?;
    Some(pages * 4096)
}

/// `make()`'s value and how much the address space grew while it ran (`None` where that cannot
/// be read).
pub fn measured<T>(make: impl FnOnce() -> T) -> (T, Option<u64>) {
    let before = mapped_bytes();
    let v = make();
    let after = mapped_bytes();
    (v, before.zip(after).map(|(b, a)| a.saturating_sub(b)))
}

/// Whether `bytes` of address space can be had now: reserved (never touched, so never made
/// resident) and given back.
pub fn available(bytes: u64) -> bool {
    let Ok(n) = usize::try_from(bytes) else {
        return false;
    };
    let mut v: Vec<u8> = Vec::new();
    v.try_reserve_exact(n).is_ok()
}

/// The address space the allocator reserves for `threads` new threads: glibc gives threads
/// arenas of 64 MiB each, up to 8 per core (none elsewhere).
pub fn thread_arenas(threads: usize) -> u64 {
    if !cfg!(target_env = "gnu") {
        return 0;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    threads.min(8 * cores) as u64 * (64 << 20)
}

/// Mebibytes, rounded up, for messages.
pub fn mib(bytes: u64) -> u64 {
    bytes.div_ceil(1 << 20)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_a_value_maps_is_measured_and_absurd_reservations_are_refused() {
        if mapped_bytes().is_none() {
            return;
        }
        let (v, grew) = measured(|| std::hint::black_box(vec![1u8; 64 << 20]));
        assert_eq!(v.len(), 64 << 20);
        let grew = grew.unwrap();
        // The vector, give or take what the other tests' threads map and unmap meanwhile (their
        // stacks and buffers: kB to a few MiB; one run saw 12 kB less than the vector).
        assert!(grew >= 60 << 20, "{grew}");
        assert!(available(1 << 20));
        assert!(!available(u64::MAX));
        assert_eq!(mib(1), 1);
    }
}
