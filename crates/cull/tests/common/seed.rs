//! The one proptest configuration every property test of the workspace uses (the unit
//! tests of `tiledlight-cull`, its integration tests, and the GPU property test in
//! `tests/`), so that plain `cargo test` draws the same cases as `cargo xtask test` and CI:
//! a new random failure must never turn an unrelated change red. `PROPTEST_RNG_SEED=s`
//! explores other cases, `PROPTEST_CASES=n` runs more of them; every other `PROPTEST_*`
//! variable works as proptest documents. Depends on proptest only (it is included by path
//! from `src/lib.rs` under `cfg(test)` and from `tests/common/mod.rs`).

use proptest::test_runner::{Config, RngSeed};

/// The seed when `PROPTEST_RNG_SEED` is unset. `xtask/src/test.rs` passes the same value
/// explicitly (it prints it), so both ways of running the suite draw identical cases.
pub const DEFAULT_SEED: u64 = 20_261_122;

/// `cases` cases (unless `PROPTEST_CASES` says otherwise) drawn from [`DEFAULT_SEED`]
/// (unless `PROPTEST_RNG_SEED` says otherwise); everything else as proptest's default,
/// which reads the other `PROPTEST_*` variables.
pub fn proptest_config(cases: u32) -> Config {
    config_from(cases, |k| std::env::var_os(k).is_some())
}

/// [`proptest_config`] with the environment as a function (`set` says whether a variable
/// is set), so the choice can be tested without touching the process environment.
pub fn config_from(cases: u32, set: impl Fn(&str) -> bool) -> Config {
    let mut c = Config::default();
    if !set("PROPTEST_CASES") {
        c.cases = cases;
    }
    if !set("PROPTEST_RNG_SEED") {
        c.rng_seed = RngSeed::Fixed(DEFAULT_SEED);
    }
    c
}
