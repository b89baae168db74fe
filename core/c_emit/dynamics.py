"""C emitters of the output-dynamics stages of :mod:`core.stages`: the resonance (an FOH
discretised transfer function), the lag and creep banks (and their inverses), the delay and
the advance."""

from __future__ import annotations

from ..stages import (
    Advance,
    Creep,
    CreepInverse,
    Delay,
    Lag,
    LagInverse,
    Resonance,
    ResonanceInverse,
    delay_split,
    discretised_tf,
)
from .stage import (
    CExportError,
    CStage,
    StageContext,
    c_array,
    c_double,
    first_sample,
    register_c_stage,
)


@register_c_stage(Resonance)
@register_c_stage(ResonanceInverse)
def _emit_foh_filter(model: Resonance | ResonanceInverse, ctx: StageContext) -> CStage:
    """FOH-discretised transfer function, direct form II transposed (as ``lfilter``)."""

    assert ctx.dt is not None
    num, den = model._tf()
    b, a, zi = discretised_tf(num, den, ctx.dt)
    n, f, c = a.size - 1, ctx.field, ctx.const
    step = [
        *first_sample(f, [f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = {c}ZI[i] * x;"]),
        f"{{ const double y = {c}B[0] * x + st->{f}z[0];",
        f"  for (i = 0; i + 1 < {n}u; ++i) "
        f"st->{f}z[i] = {c}B[i + 1] * x + st->{f}z[i + 1] - {c}A[i + 1] * y;",
        f"  st->{f}z[{n - 1}] = {c}B[{n}] * x - {c}A[{n}] * y;",
        "  x = y; }",
    ]
    return CStage(
        title=f"{model.type_name} (FOH, dt = {ctx.dt:g} s), order {n}",
        fields=[f"double {f}z[{n}];", f"int {f}started;"],
        constants=[
            f"static const double {c}B[{n + 1}] = {c_array(b)};",
            f"static const double {c}A[{n + 1}] = {c_array(a)};",
            f"static const double {c}ZI[{n}] = {c_array(zi)};",
        ],
        reset=[f"st->{f}started = 0;", f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = 0.0;"],
        step=step,
        tune=_resonance_tune(model, n, c, ctx.dt),
        tune_helpers=_foh_helper(n, c),
    )


def _resonance_tune(model: Resonance | ResonanceInverse, n: int, c: str, dt: float) -> list[str]:
    """``num``/``den`` of ``Resonance._tf`` / ``ResonanceInverse._tf`` from the fields, then
    the FOH discretisation (:func:`_foh_helper`)."""
    lines = [f"{{ double num[{n + 1}], den[{n + 1}];",
             "  const double w = 2.0 * 3.141592653589793 * $freq_hz[0];",
             "  const double z2w = 2.0 * $damping[0] * w;"]
    if isinstance(model, ResonanceInverse):
        lines += ["  const double wc = 2.0 * 3.141592653589793 * $bandwidth_hz[0];",
                  "  const double g = wc * wc / (w * w);",
                  "  num[0] = g * 3.0; num[1] = g * (wc + z2w * 3.0);",
                  "  num[2] = g * (z2w * wc + w * w * 3.0); num[3] = g * (w * w * wc);",
                  "  den[0] = 1.0; den[1] = 3.0 * wc; den[2] = 3.0 * wc * wc;",
                  "  den[3] = wc * wc * wc;"]
    else:
        lines += ["  num[0] = 0.0; num[1] = 0.0; num[2] = w * w;",
                  "  den[0] = 1.0; den[1] = z2w; den[2] = w * w;"]
    return [*lines, f"  {c}foh(num, den, {c_double(dt)}, {c}B, {c}A, {c}ZI); }}"]


def _foh_helper(n: int, c: str) -> list[str]:
    """C of ``{c}foh(num, den, dt, b, a, zi)``: the first-order-hold discretisation of the
    order-``n`` transfer function ``num(s)/den(s)`` (``num`` padded to ``n + 1``) as
    :func:`core.stages.discretised_tf`: the frequency is scaled to ``|den_n/den_0|^(1/n)``
    (a well-conditioned companion form), ``expm`` of the FOH block matrix (Taylor series
    with scaling and squaring), the discrete polynomials by Faddeev-LeVerrier and
    ``lfilter_zi`` by Gaussian elimination."""
    m = n + 2
    return [
        f"/* FOH discretisation of an order-{n} transfer function (see core/export_c.py) */",
        f"static void {c}charpoly(double A[{n}][{n}], double *p)",
        "{",
        f"    double Mk[{n}][{n}], T[{n}][{n}];",
        "    unsigned i, j, l, k;",
        "    memset(Mk, 0, sizeof Mk);",
        "    p[0] = 1.0;",
        f"    for (k = 1; k <= {n}u; ++k) {{",
        "        double tr = 0.0;",
        f"        for (i = 0; i < {n}u; ++i) for (j = 0; j < {n}u; ++j) {{",
        "            double s = i == j ? p[k - 1] : 0.0;",
        f"            for (l = 0; l < {n}u; ++l) s += A[i][l] * Mk[l][j];",
        "            T[i][j] = s;",
        "        }",
        "        memcpy(Mk, T, sizeof Mk);",
        f"        for (i = 0; i < {n}u; ++i)",
        f"            for (l = 0; l < {n}u; ++l) tr += A[i][l] * Mk[l][i];",
        "        p[k] = -tr / (double)k;",
        "    }",
        "}",
        f"static void {c}foh(const double *num, const double *den, double dt, double *b,",
        "                   double *a, double *zi)",
        "{",
        f"    double sc[{n + 1}], an[{n + 1}], bn[{n + 1}], C[{n}], w, D, Dd, nrm;",
        f"    double X[{m}][{m}], E[{m}][{m}], T[{m}][{m}], S[{m}][{m}];",
        f"    double Ad[{n}][{n}], Ab[{n}][{n}], Bd[{n}], q[{n}], G[{n}][{n + 1}];",
        "    unsigned i, j, l, k, s = 0u;",
        f"    w = pow(fabs(den[{n}] / den[0]), 1.0 / {n}.0);",
        f"    sc[{n}] = 1.0;",
        f"    for (i = {n}u; i > 0u; --i) sc[i - 1] = sc[i] * w;",
        f"    for (i = 0; i <= {n}u; ++i) {{",
        "        an[i] = den[i] / den[0] * sc[i] / sc[0];",
        "        bn[i] = num[i] / den[0] * sc[i] / sc[0];",
        "    }",
        "    dt *= w;",
        "    D = bn[0];",
        f"    for (i = 0; i < {n}u; ++i) C[i] = bn[i + 1] - an[i + 1] * D;",
        "    memset(X, 0, sizeof X);",
        f"    for (j = 0; j < {n}u; ++j) X[0][j] = -an[j + 1] * dt;",
        f"    for (i = 1; i < {n}u; ++i) X[i][i - 1] = dt;",
        f"    X[0][{n}] = dt;",
        f"    X[{n}][{n + 1}] = 1.0;",
        "    nrm = 0.0;",
        f"    for (i = 0; i < {m}u; ++i) {{",
        "        double r = 0.0;",
        f"        for (j = 0; j < {m}u; ++j) r += fabs(X[i][j]);",
        "        if (r > nrm) nrm = r;",
        "    }",
        "    while (nrm > 0.5) { nrm *= 0.5; ++s; }",
        f"    for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "        X[i][j] = ldexp(X[i][j], -(int)s);",
        "        E[i][j] = T[i][j] = i == j ? 1.0 : 0.0;",
        "    }",
        "    for (k = 1; k < 40u; ++k) { /* Taylor series of expm(X), |X| <= 1/2 */",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "            double v = 0.0;",
        f"            for (l = 0; l < {m}u; ++l) v += T[i][l] * X[l][j];",
        "            S[i][j] = v / (double)k;",
        "        }",
        "        memcpy(T, S, sizeof T);",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) E[i][j] += T[i][j];",
        "    }",
        "    for (k = 0; k < s; ++k) { /* squaring */",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "            double v = 0.0;",
        f"            for (l = 0; l < {m}u; ++l) v += E[i][l] * E[l][j];",
        "            S[i][j] = v;",
        "        }",
        "        memcpy(E, S, sizeof E);",
        "    }",
        "    Dd = D;",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        double v = E[i][{n}] - E[i][{n + 1}];",
        f"        for (j = 0; j < {n}u; ++j) {{",
        "            Ad[i][j] = E[i][j];",
        f"            v += E[i][j] * E[j][{n + 1}];",
        "        }",
        "        Bd[i] = v;",
        f"        Dd += C[i] * E[i][{n + 1}];",
        "    }",
        f"    for (i = 0; i < {n}u; ++i)",
        f"        for (j = 0; j < {n}u; ++j) Ab[i][j] = Ad[i][j] - Bd[i] * C[j];",
        f"    {c}charpoly(Ad, a);",
        f"    {c}charpoly(Ab, b);",
        f"    for (i = 0; i <= {n}u; ++i) b[i] += (Dd - 1.0) * a[i];",
        "    /* lfilter_zi: (I - companion(a)^T) zi = b[1:] - a[1:] b[0] */",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        for (j = 0; j < {n}u; ++j) G[i][j] = i == j ? 1.0 : 0.0;",
        "        G[i][0] += a[i + 1];",
        f"        if (i + 1 < {n}u) G[i][i + 1] -= 1.0;",
        f"        G[i][{n}] = b[i + 1] - a[i + 1] * b[0];",
        "    }",
        f"    for (k = 0; k < {n}u; ++k) {{ /* elimination, partial pivoting */",
        "        unsigned p = k;",
        f"        for (i = k + 1; i < {n}u; ++i) if (fabs(G[i][k]) > fabs(G[p][k])) p = i;",
        f"        for (j = 0; j <= {n}u; ++j) {{",
        "            const double t = G[k][j];",
        "            G[k][j] = G[p][j];",
        "            G[p][j] = t;",
        "        }",
        f"        for (i = k + 1; i < {n}u; ++i) {{",
        "            const double f = G[i][k] / G[k][k];",
        f"            for (j = k; j <= {n}u; ++j) G[i][j] -= f * G[k][j];",
        "        }",
        "    }",
        f"    for (i = {n}u; i > 0u; --i) {{",
        f"        double v = G[i - 1][{n}];",
        f"        for (j = i; j < {n}u; ++j) v -= G[i - 1][j] * q[j];",
        "        q[i - 1] = v / G[i - 1][i - 1];",
        "    }",
        f"    for (i = 0; i < {n}u; ++i) zi[i] = q[i];",
        "}",
    ]


@register_c_stage(Lag)
@register_c_stage(Creep)
@register_c_stage(LagInverse)
@register_c_stage(CreepInverse)
def _emit_lag_bank(model: Lag | Creep | LagInverse | CreepInverse, ctx: StageContext) -> CStage:
    """Bank of first-order lags ``y = g0 x + sum c_j L_j[x]`` or its exact per-sample inverse."""

    assert ctx.dt is not None
    inverse = isinstance(model, LagInverse | CreepInverse)
    if isinstance(model, CreepInverse):
        bank = model.checked_bank(ctx.dt)
    elif isinstance(model, LagInverse):
        bank = Lag(model.tau_s).bank(ctx.dt)
    else:
        assert isinstance(model, Lag | Creep)
        bank = model.bank(ctx.dt)
    m, f, c = bank.c.size, ctx.field, ctx.const
    consts = [
        *([] if inverse else [f"static const double {c}G0 = {c_double(bank.g0)};"]),
        f"static const double {c}C[{m}] = {c_array(bank.c)};",
        f"static const double {c}B0[{m}] = {c_array(bank.b0)};",
        f"static const double {c}B1[{m}] = {c_array(bank.b1)};",
        f"static const double {c}A1[{m}] = {c_array(bank.a1)};",
        f"static const double {c}ZI[{m}] = {c_array(bank.zi)};",
    ]
    init = [f"for (i = 0; i < {m}u; ++i) st->{f}s[i] = {c}ZI[i] * x;"]
    update = [
        f"for (i = 0; i < {m}u; ++i) {{",
        f"    const double l = {c}B0[i] * x + st->{f}s[i];",
        f"    st->{f}s[i] = {c}B1[i] * x - {c}A1[i] * l;",
    ]
    if inverse:
        consts.append(f"static const double {c}GAIN = {c_double(bank.gain0)};")
        step = [
            *first_sample(f, init),
            "{ double acc = x;",
            f"  for (i = 0; i < {m}u; ++i) acc -= {c}C[i] * st->{f}s[i];",
            f"  x = acc / {c}GAIN; }}",
            *update, "}",
        ]
    else:
        step = [
            *first_sample(f, init),
            f"{{ double acc = {c}G0 * x;",
            *(f"  {line}" for line in update),
            f"      acc += {c}C[i] * l;",
            "  }",
            "  x = acc; }",
        ]
    return CStage(
        title=f"{model.type_name}: {m} first-order lag(s) (FOH, dt = {ctx.dt:g} s)",
        fields=[f"double {f}s[{m}];", f"int {f}started;"],
        constants=consts,
        reset=[f"st->{f}started = 0;", f"for (i = 0; i < {m}u; ++i) st->{f}s[i] = 0.0;"],
        step=step,
        tune=_lag_bank_tune(model, m, c, ctx.dt, inverse),
    )


def _lag_bank_tune(model: Lag | Creep | LagInverse | CreepInverse, m: int, c: str, dt: float,
                   inverse: bool) -> list[str]:
    """First-order FOH sections from the time constants (as ``LagBank.of``, closed form:
    ``p = exp(-dt/tau)``, ``q = tau/dt (1 - p)``, ``b0 = 1 - q``, ``b1 = q - p``)."""
    single = isinstance(model, Lag | LagInverse)
    tau, w = ("$tau_s[0]", "1.0") if single else ("$taus_s[i]", "$weights[i]")
    dts = c_double(dt)
    return [
        f"{{ double g0 = {'0.0' if single else '1.0'}, gain;",
        f"  for (i = 0; i < {m}u; ++i) {{",
        f"      const double p = exp(-{dts} / {tau});",
        f"      const double q = {tau} / {dts} * (1.0 - p);",
        f"      {c}C[i] = {w}; {c}B0[i] = 1.0 - q; {c}B1[i] = q - p; {c}A1[i] = -p;",
        f"      {c}ZI[i] = q;",
        *([] if single else [f"      g0 -= {c}C[i];"]),
        "  }",
        "  gain = g0;",
        f"  for (i = 0; i < {m}u; ++i) gain += {c}C[i] * {c}B0[i];",
        f"  {c}GAIN = gain; }}" if inverse else f"  {c}G0 = g0; (void)gain; }}",
    ]


@register_c_stage(Delay)
def _emit_delay(model: Delay, ctx: StageContext) -> CStage:
    """Fractional delay ``m + f`` samples: ring buffer of the last ``m + 2`` inputs."""

    assert ctx.dt is not None
    m, frac = delay_split(model.delay_s, ctx.dt)
    size, f, c = m + 2, ctx.field, ctx.const
    return CStage(
        title=f"delay of {m} + {frac:.6g} sample(s) (dt = {ctx.dt:g} s)",
        fields=[f"double {f}h[{size}];", f"unsigned {f}pos;", f"int {f}started;"],
        constants=[f"static const double {c}F = {c_double(frac)};"],
        reset=[f"st->{f}started = 0;", f"st->{f}pos = 0u;",
               f"for (i = 0; i < {size}u; ++i) st->{f}h[i] = 0.0;"],
        step=[
            *first_sample(f, [f"for (i = 0; i < {size}u; ++i) st->{f}h[i] = x;"]),
            f"st->{f}h[st->{f}pos] = x;",
            f"{{ const double newer = st->{f}h[(st->{f}pos + {size - m}u) % {size}u];",
            f"  const double older = st->{f}h[(st->{f}pos + {size - m - 1}u) % {size}u];",
            f"  st->{f}pos = (st->{f}pos + 1u) % {size}u;",
            f"  x = {c}F * older + (1.0 - {c}F) * newer; }}",
        ],
        tune=[  # as delay_split; the whole samples size the buffer: another count is refused
            f"{{ const double d = $delay_s[0] / {c_double(ctx.dt)};",
            "  const double m = floor(d + 1e-12);",
            f"  {c}F = m != {float(m)} ? NAN : d - m > 0.0 ? d - m : 0.0; }}",
        ],
    )


@register_c_stage(Advance)
def _emit_advance(model: Advance, ctx: StageContext) -> CStage:
    """An advance only exists with preview: emitted through :func:`core.stages.causal_form`."""
    raise CExportError(
        "an 'advance' (inverse of a delay) needs the future; export the forward model's "
        "inverse (the compensator applies the preview: <name>_INV_PREVIEW)"
    )
