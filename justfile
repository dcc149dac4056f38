# stickslip task runner (https://github.com/casey/just)

# Run the whole test suite (what CI runs first).
test:
    cargo test --all-targets

# Lint and format checks.
lint:
    cargo clippy --all-targets -- -D warnings
    cargo fmt --all -- --check

# Criterion benchmarks of the engine.
bench:
    cargo bench --bench engine
    cargo bench --bench ingest

# The main job on the bundled data (for now: a steady simulation).
main:
    cargo run --release -- simulate --rho-s 0.375 --eta 0.6 --steady

# CI as it runs on a fresh clone.
ci:
    bash .ci/run
