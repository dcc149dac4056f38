# stickslip task runner (https://github.com/casey/just)

# Run the whole test suite (what CI runs first; --all-targets skips doctests).
test:
    cargo test --all-targets
    cargo test --doc

# Lint and format checks.
lint:
    cargo clippy --all-targets -- -D warnings
    cargo fmt --all -- --check
    cargo check --lib --no-default-features

# Criterion benchmarks (engine, Fig. 3 family, ingest) and the
# work-precision study.
bench:
    cargo bench --bench engine
    cargo bench --bench sweep
    cargo bench --bench ingest
    cargo bench --bench fit
    cargo run --release -- bench

# The main job: the whole pipeline on the bundled data set's plan
# (ingest -> fit -> validate -> batch), report in reports/index.html.
main:
    cargo run --release -- run datasets/plan.toml --report reports

# Render the report in headless Chromium (Debian: apt install chromium) and
# save a screenshot (/tmp/stickslip-report.png) to look at.
screenshot:
    chromium --headless --no-sandbox --disable-gpu --disable-background-networking --disable-component-update --no-first-run --hide-scrollbars --window-size=1200,4000 --screenshot=/tmp/stickslip-report.png "file://$(pwd)/reports/index.html"

# CI as it runs on a fresh clone.
ci:
    bash .ci/run

# Regenerate the paper's Figs. 3-5 (Coulomb; decreasing D* = -0.04 interrupted
# below rho_s/2; rho_d = rho_s/2), the coexisting-states figure and the
# real-pad figures (pre-sliding; direction-dependent levels) into reports/.
figures:
    cargo run --release -- sweep --plot reports/fig3.svg --out reports/fig3.parquet --title "Fig. 3: Coulomb friction"
    cargo run --release -- sweep --slope -0.04 --stop-below 0.5 --plot reports/fig4.svg --out reports/fig4.parquet --title "Fig. 4: decreasing characteristic D* = -0.04 (interrupted below rho_s/2)"
    cargo run --release -- sweep --rho-d-ratio 0.5 --plot reports/fig5.svg --out reports/fig5.parquet --title "Fig. 5: rho_d = rho_s/2"
    cargo run --release -- sweep --rho-s 1 --rho-d-ratio 0.5 --direction both --plot reports/coexisting.svg --title "Coexisting stable states: rho_s 1, rho_d 0.5, continued up and down"
    cargo run --release -- sweep --rho-s 0.5 --rho-d 0.4 --contact-stiffness inf,20,5 --from-rest --plot reports/contact.svg --title "Pre-sliding: rho_s 0.5, rho_d 0.4 with a rigid stick and contact stiffness 20 and 5 (from rest)"
    cargo run --release -- sweep --rho-s 0.5 --rho-d 0.4 --rho-s-minus 0.35 --rho-d-minus 0.3 --direction both --plot reports/direction.svg --title "Direction-dependent pad: rho_s 0.5 / 0.35, rho_d 0.4 / 0.3 (forwards / backwards), up and down"

# Identification studies: adequacy right both ways (60 in-family logs of
# four rigs with realistic sensors, docs/measurements.md), round trips
# through the virtual rig (200 random logs), repeatability under new sensor
# draws, the long coverage run.
studies:
    cargo build --release
    python3 scripts/adequacy_study.py target/adequacy-study 60
    python3 scripts/adequacy_eval.py target/adequacy-study target/release/stickslip
    cargo test --release --test fit_synth -- --ignored --nocapture
    cargo test --release --test identify_roundtrip -- --ignored --nocapture
    cargo test --release --test identify_other_rigs -- --ignored --nocapture
    cargo test --release --test defects -- --ignored --nocapture

# Mutation-fuzz the ingest parsers and the channel-map parser, 300 s each
# (seeded from datasets/; cargo-fuzz would need a nightly toolchain).
fuzz:
    STICKSLIP_FUZZ_SECS=300 cargo test --release --test fuzz -- --nocapture

# The golden record of every command's --json on datasets/ (issue 15):
# compare with tests/golden/ (GOLDEN_RECORD=1 re-makes it, GOLDEN_RTOL
# loosens the comparison to list numeric changes).
golden:
    cargo test --release --test golden -- --ignored --test-threads 2

# Run the Slurm recipes of docs/cluster.md (scripts/slurm/*.sbatch, as they
# are) on a one-node Slurm started and stopped here, and compare with the
# unsharded results bit for bit (root on Debian; installs slurm-wlm and munge
# with apt; not part of CI).
slurm-check:
    cargo build --release
    scripts/slurm_check.sh
