//! Fuzzes `DelayDist::parse` (delay spec strings such as `poisson:13` or
//! `mix:0.5*const:2+0.5*poisson:20`, or in seconds `exponential:4s`, `hist@0.5s:1,2`):
//! any string gives a distribution or an error, never a panic; an accepted distribution
//! has a finite mean within the supported range, a working sampler (delays in seconds:
//! finite and ≥ 0) and a printed form that parses again.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mmq_core::DelayDist;
use mmq_core::delay::MAX_MEAN_DELAY;

fuzz_target!(|data: &[u8]| {
    let Ok(spec) = std::str::from_utf8(data) else { return };
    let Ok(d) = DelayDist::parse(spec) else { return };
    let mean = d.mean();
    assert!(mean.is_finite() && (0.0..=MAX_MEAN_DELAY).contains(&mean), "{spec}: mean {mean}");
    let _ = d.variance();
    for k in 0..4 {
        let p = d.pmf(k);
        assert!(!p.is_nan(), "{spec}: pmf({k}) = {p}");
    }
    let s = d.sampler();
    let mut rng = mmq_core::seed::rng_from_seed(7);
    for _ in 0..16 {
        let _ = s.sample(&mut rng);
    }
    if let Some(sd) = d.as_seconds() {
        let s = sd.sampler();
        for _ in 0..16 {
            let x = s.sample(&mut rng);
            assert!(x.is_finite() && x >= 0.0, "{spec}: drew {x} s");
        }
    }
    let printed = d.to_string();
    let _ = DelayDist::parse(&printed);
});
