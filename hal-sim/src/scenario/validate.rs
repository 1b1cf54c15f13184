//! A scenario's checks: every field in its range, the schedule, the body, the reference, the
//! environment and each part against its bus; each error names what is wrong.

use super::*;

impl Scenario {
    pub(super) fn validate(&self) -> Result<(), String> {
        if !(self.rate.is_finite() && self.rate > 0.0 && self.rate <= 4000.0) {
            return Err(format!(
                "rate = {}: expected 0 < rate <= 4000 Hz",
                self.rate
            ));
        }
        if !(self.duration.is_finite() && self.duration > 0.0 && self.duration <= 1e6) {
            return Err(format!(
                "duration = {}: expected 0 < duration <= 1e6 s",
                self.duration
            ));
        }
        if let Some(m) = &self.model {
            if ballisto_config::arrangement_file::parse_model(m).is_none() {
                return Err(format!("model = \"{m}\": expected general or free-float"));
            }
        }
        if self.initial_omega.is_some_and(|w| !finite(&w)) {
            return Err("initial_omega: not finite".into());
        }
        self.validate_body()?;
        self.validate_environment()?;
        self.validate_reference()?;
        if let Some(t) = &self.temperature {
            t.check()?;
        }
        let mut buses = HashSet::new();
        for b in &self.buses {
            if b.kind != "spi" && b.kind != "i2c" {
                return Err(format!(
                    "bus \"{}\": kind = \"{}\": expected spi or i2c",
                    b.name, b.kind
                ));
            }
            if !(b.clock_hz.is_finite() && b.clock_hz > 0.0) {
                return Err(format!("bus \"{}\": clock_hz must be positive", b.name));
            }
            if !buses.insert(b.name.as_str()) {
                return Err(format!("bus \"{}\" is declared twice", b.name));
            }
        }
        if self.parts.is_empty() {
            return Err("no [[part]]".into());
        }
        let mut names = HashSet::new();
        let mut slots = HashSet::new();
        for p in &self.parts {
            if !names.insert(p.name.as_str()) {
                return Err(format!("part \"{}\" is declared twice", p.name));
            }
            let slot = self.validate_part(p)?;
            if !slots.insert((p.bus.as_str(), slot)) {
                return Err(format!(
                    "part \"{}\": {} {slot} on bus \"{}\" is taken by another part",
                    p.name,
                    if p.part == PartType::Adxl355 {
                        "chip select"
                    } else {
                        "address"
                    },
                    p.bus
                ));
            }
        }
        for (i, f) in self.faults.iter().enumerate() {
            self.fault(f)
                .map_err(|m| format!("fault {} (part \"{}\"): {m}", i + 1, f.part))?;
        }
        Ok(())
    }

    fn validate_body(&self) -> Result<(), String> {
        let b = &self.body;
        for (name, v) in [
            ("inertia", b.inertia.as_ref().map(|v| &v[..])),
            ("omega0", b.omega0.as_ref().map(|v| &v[..])),
            ("attitude0", b.attitude0.as_ref().map(|v| &v[..])),
            ("origin_offset", b.origin_offset.as_ref().map(|v| &v[..])),
        ] {
            if v.is_some_and(|v| !finite(v)) {
                return Err(format!("body.{name}: not finite"));
            }
        }
        if b.attitude0
            .is_some_and(|q| q.iter().map(|v| v * v).sum::<f64>() < 1e-12)
        {
            return Err("body.attitude0: zero quaternion".into());
        }
        if let Some(segments) = &b.schedule {
            if b.turntable.is_some()
                || b.inertia.is_some()
                || b.torque.is_some()
                || b.omega0.is_some()
            {
                return Err(
                    "body: a schedule excludes inertia, omega0, torque and turntable".into(),
                );
            }
            return validate_schedule(segments);
        }
        match (&b.turntable, &b.inertia) {
            (Some(_), Some(_)) => {
                Err("body: give either inertia (free rotation) or turntable, not both".into())
            }
            (None, None) => Err("body: needs inertia (free rotation) or turntable".into()),
            (Some(t), None) => {
                if b.torque.is_some() || b.omega0.is_some() {
                    return Err(
                        "body: torque and omega0 apply to free rotation, not to a turntable".into(),
                    );
                }
                let n = t.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
                if !(finite(&t.axis) && n > 1e-9) {
                    return Err("body.turntable.axis: zero or not finite".into());
                }
                if !(t.rate.is_finite() && t.spin_up.is_finite() && t.spin_up >= 0.0) {
                    return Err(
                        "body.turntable: rate and spin_up must be finite, spin_up >= 0".into(),
                    );
                }
                Ok(())
            }
            (None, Some(i)) => {
                if i.iter().any(|v| *v <= 0.0) {
                    return Err("body.inertia: moments must be positive".into());
                }
                if i[0] + i[1] < i[2] || i[0] + i[2] < i[1] || i[1] + i[2] < i[0] {
                    return Err(
                        "body.inertia: violates the triangle inequality of a rigid body".into(),
                    );
                }
                match &b.torque {
                    Some(TorqueSpec::Sinusoid {
                        amplitude,
                        frequency,
                        phase,
                    }) if !(finite(amplitude) && frequency.is_finite() && finite(phase)) => {
                        Err("body.torque: not finite".into())
                    }
                    Some(TorqueSpec::Steps { steps })
                        if !steps.iter().all(|s| finite(s))
                            || steps.windows(2).any(|w| w[1][0] < w[0][0]) =>
                    {
                        Err("body.torque.steps: not finite or start times not ascending".into())
                    }
                    _ => Ok(()),
                }
            }
        }
    }

    fn validate_reference(&self) -> Result<(), String> {
        let Some(r) = &self.reference else {
            return Ok(());
        };
        if !(r.noise_density.is_finite() && r.noise_density >= 0.0 && finite(&r.bias)) {
            return Err("reference: noise_density must be finite and >= 0, bias finite".into());
        }
        if let Some(rate) = r.rate {
            let n = self.rate / rate;
            if !(rate.is_finite() && rate > 0.0 && (n - n.round()).abs() < 1e-9 && n >= 1.0) {
                return Err(format!(
                    "reference.rate = {rate}: must be the scenario rate {} divided by a whole number",
                    self.rate
                ));
            }
        }
        Ok(())
    }

    fn validate_environment(&self) -> Result<(), String> {
        let e = &self.environment;
        match (e.kind.as_str(), e.altitude) {
            ("orbit", Some(a)) if a.is_finite() && a > 0.0 => {}
            ("orbit", _) => return Err("environment: orbit needs altitude > 0 (m)".into()),
            ("space" | "ground", None) => {}
            ("space" | "ground", Some(_)) => {
                return Err(format!(
                    "environment: altitude applies to orbit, not {}",
                    e.kind
                ))
            }
            (k, _) => {
                return Err(format!(
                    "environment.kind = \"{k}\": expected space, orbit or ground"
                ))
            }
        }
        if e.drag.is_some_and(|d| !finite(&d)) {
            return Err("environment.drag: not finite".into());
        }
        for (i, b) in e.burns.iter().enumerate() {
            if !(finite(&b.accel) && b.start.is_finite() && b.end.is_finite() && b.end > b.start) {
                return Err(format!(
                    "environment.burn {}: needs finite accel and start < end",
                    i + 1
                ));
            }
        }
        Ok(())
    }

    /// Checks one part; returns its chip select or address.
    fn validate_part(&self, p: &PartSpec) -> Result<usize, String> {
        let err = |m: String| format!("part \"{}\": {m}", p.name);
        let bus = self
            .buses
            .iter()
            .find(|b| b.name == p.bus)
            .ok_or_else(|| err(format!("bus \"{}\" is not declared", p.bus)))?;
        let slot = match (p.part, bus.kind.as_str(), p.cs, p.address) {
            (PartType::Adxl355, "spi", Some(cs), None) if cs < 64 => cs,
            (PartType::Adxl355, "spi", _, _) => {
                return Err(err("an SPI part needs cs (0..63) and no address".into()))
            }
            (PartType::Lis3dh, "i2c", None, Some(a)) if a == 0x18 || a == 0x19 => usize::from(a),
            (PartType::Lis3dh, "i2c", _, _) => {
                return Err(err(
                    "the LIS3DH needs address 0x18 or 0x19 (SA0) and no cs".into()
                ))
            }
            (t, k, _, _) => {
                return Err(err(format!(
                    "a {} cannot be on a {k} bus (this model has it on {})",
                    t.label(),
                    if t == PartType::Adxl355 { "SPI" } else { "I2C" }
                )))
            }
        };
        if !finite(&p.position) {
            return Err(err("position: not finite".into()));
        }
        if p.position_error.is_some_and(|e| !finite(&e)) {
            return Err(err("position_error: not finite".into()));
        }
        if p.orientation_error
            .is_some_and(|e| !finite(&e) || e.iter().map(|v| v * v).sum::<f64>() > 0.01)
        {
            return Err(err(
                "orientation_error: must be finite and small (|r| <= 0.1 rad)".into(),
            ));
        }
        let m = p.orientation.unwrap_or(IDENTITY);
        if !m.iter().all(|r| finite(r)) || rotation_defect(&m, 1e-6).is_some() {
            return Err(err("orientation: not a proper rotation matrix".into()));
        }
        if let Some(axes) = &p.axes {
            let mut seen = HashSet::new();
            if axes.is_empty() {
                return Err(err("axes: empty".into()));
            }
            for a in axes {
                if !AXES.contains(&a.as_str()) || !seen.insert(a) {
                    return Err(err(format!(
                        "axes: \"{a}\" is not x, y or z or is repeated"
                    )));
                }
            }
        }
        if let Some(r) = p.range_g {
            if !p.part.ranges().contains(&r) {
                return Err(err(format!(
                    "range_g = {r}: the {} offers {:?} g",
                    p.part.label(),
                    p.part.ranges()
                )));
            }
        }
        if let Some(o) = p.odr {
            if !p.part.odrs().contains(&o) {
                return Err(err(format!(
                    "odr = {o}: the {} offers {:?} Hz",
                    p.part.label(),
                    p.part.odrs()
                )));
            }
            if o < self.rate && !(p.part == PartType::Adxl355 && self.sync(p)) {
                return Err(err(format!(
                    "odr = {o} Hz is below the read rate {} Hz",
                    self.rate
                )));
            }
        }
        if p.sync == Some(true) && p.part != PartType::Adxl355 {
            return Err(err(format!("sync: the {} has no SYNC pin", p.part.label())));
        }
        let finite_opt = |v: Option<&[f64]>| v.is_none_or(finite);
        if !(finite_opt(p.scale.as_ref().map(|v| &v[..]))
            && finite_opt(p.bias.as_ref().map(|v| &v[..]))
            && p.cross.is_none_or(|c| c.iter().all(|r| finite(r))))
        {
            return Err(err("scale, bias or cross: not finite".into()));
        }
        for (name, v) in [("noise_density", p.noise_density), ("jitter", p.jitter)] {
            if v.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
                return Err(err(format!("{name}: must be finite and >= 0")));
            }
        }
        if p.clock_ppm
            .is_some_and(|v| !(v.is_finite() && v.abs() < 1e5))
        {
            return Err(err("clock_ppm: must be finite, |ppm| < 1e5".into()));
        }
        use estimator_core::thermal::{BIAS_TC_MAX, SCALE_TC_MAX};
        for (name, v, max) in [
            ("bias_tc", p.bias_tc, BIAS_TC_MAX),
            ("scale_tc", p.scale_tc, SCALE_TC_MAX),
        ] {
            if v.is_some_and(|v| !v.iter().all(|x| x.is_finite() && x.abs() <= max)) {
                return Err(err(format!("{name}: must be finite and within ±{max}")));
            }
        }
        if p.thermal_lag.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
            return Err(err("thermal_lag: must be finite and >= 0 (s)".into()));
        }
        if p.temp_offset
            .is_some_and(|v| !(v.is_finite() && v.abs() <= 50.0))
        {
            return Err(err("temp_offset: must be finite, within ±50 °C".into()));
        }
        Ok(slot)
    }
}

fn validate_schedule(segments: &[SegmentSpec]) -> Result<(), String> {
    if segments.is_empty() {
        return Err("body.schedule: empty".into());
    }
    for (i, seg) in segments.iter().enumerate() {
        let err = |m: &str| format!("body.schedule segment {}: {m}", i + 1);
        let (duration, axis, ok) = match seg {
            SegmentSpec::Rest { duration } => (*duration, None, true),
            SegmentSpec::Rotate {
                axis,
                angle,
                duration,
            } => (*duration, Some(axis), angle.is_finite()),
            SegmentSpec::Spin {
                axis,
                rate,
                ramp,
                duration,
            } => {
                let ramp = ramp.unwrap_or(1.0);
                (
                    *duration,
                    Some(axis),
                    rate.is_finite() && ramp.is_finite() && ramp >= 0.0 && 2.0 * ramp <= *duration,
                )
            }
        };
        if !(duration.is_finite() && duration > 0.0) {
            return Err(err("duration must be finite and > 0"));
        }
        if axis.is_some_and(|a| unit(a).is_none()) {
            return Err(err("axis: zero or not finite"));
        }
        if !ok {
            return Err(err(
                "angle or rate not finite, or a spin's two ramps longer than its duration",
            ));
        }
    }
    Ok(())
}
