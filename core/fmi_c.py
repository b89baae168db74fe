"""The C translation unit of an FMU: the FMI 3.0 / 2.0 co-simulation API around a model block.

:func:`fmu_c_source` wraps the model block of :mod:`core.export_c` (emitted with its stage
constants read through a pointer, ``_emit_block(..., params=...)``) in one C99 file: the
instance (stage constants, model parameters, memory), the derivation of the constants from
the parameters (the stages' ``tune`` lines), the FMI functions this FMU provides and a stub
returning an error for every other function the FMI headers declare (read from the headers
at build time). :mod:`core.export_fmu` builds the FMU around it.

Identifiers of the templates use the prefix ``HX``, replaced by the model identifier.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from .escape import c_string
from .export_c import c_double

__all__ = ["FmuCode", "fmu_c_source"]


@dataclass(frozen=True)
class FmuCode:
    """What an FMU's C file is made of.

    Attributes
    ----------
    ident : str
        Model identifier (C prefix, file stem).
    fmi_version : int
        3 or 2.
    header, body : str
        The model block ``<ident>_m`` (state struct and prototypes; its source, with the
        stage constants as ``#define``s through ``<ident>_P_`` and the tune helpers).
    constants : tuple of (str, str, int or None, str)
        Every stage constant: C type, identifier, array size (None: scalar), initialiser.
    tune : tuple of str
        Statements deriving the constants from the parameter array ``mp``.
    parameters : tuple of float
        Exported values of the model parameters (value reference ``first_vr + index``).
    kinds : tuple of int
        Per parameter: 1 tunable, 2 initial state (before initialisation only), 0 fixed.
    dt : float or None
        Sample time (s); None: one sample per step.
    preview : int
        Preview of a compensator (samples).
    inverse : bool
        A compensator (``preview_samples`` is readable).
    first_vr : int
        Value reference of the first parameter.
    names : tuple of str
        Per parameter: its variable name (for messages).
    limits : tuple of (lower, upper, strict, previous, next)
        Per parameter: the hard limits of a valid value (None: none; ``strict``: the lower
        one is exclusive) and the indices of the parameters it must stay above and below
        (an increasing field; -1: none). A Set call breaking one is refused.
    ports : (str, str)
        Names of the input and the output (for messages).
    slopes : tuple of (int, int, int)
        PI stages whose slopes must stay positive: indices of ``p0`` and the first weight
        among the parameters, and the number of weights.
    """

    ident: str
    fmi_version: int
    header: str
    body: str
    constants: tuple[tuple[str, str, int | None, str], ...]
    tune: tuple[str, ...]
    parameters: tuple[float, ...]
    kinds: tuple[int, ...]
    dt: float | None
    preview: int
    inverse: bool
    first_vr: int
    names: tuple[str, ...] = ()
    limits: tuple[tuple[float | None, float | None, bool, int, int], ...] = ()
    ports: tuple[str, str] = ("u", "y")
    slopes: tuple[tuple[int, int, int], ...] = ()


_TLS = """#if defined(_MSC_VER)
#define HYST_TLS __declspec(thread)
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define HYST_TLS _Thread_local
#else
#define HYST_TLS __thread
#endif"""

# The instance, shared by both FMI versions (HX: the model identifier). Each entry point
# that runs the model first points HX_P_ (thread-local) at the instance's constants.
_CORE = r"""
typedef struct {
    HX_params P;               /* stage constants, derived from mp */
    double mp[HX_NMP];         /* model parameters, by value reference - HX_VR0 */
    double mp_old[HX_NMP];     /* their values before the current Set call */
    unsigned char changed[HX_NMP];
    double u_old;
    HX_m_state st;             /* memory of the model */
    double u, y, time;
    long long n;               /* samples run since initialisation */
    double carry;              /* part of a sample (0 <= carry < 1) the steps so far held */
    int mode;                  /* 0 instantiated, 1 initialisation, 2 stepping, 3 terminated */
    int dirty;                 /* parameters changed since the constants were derived */
    char name[128];
    char msg[400];             /* the last message for the user */
    HX_LOGGER
} HX_inst;

#define HX_NOT_FINITE "these parameters are beyond what this export can run: a derived " \
    "coefficient would be non-finite (a zero width or frequency, an overflow), or a delay " \
    "would span another number of whole samples than exported (re-export for that)"

/* whether every derived constant is finite */
static int HX_finite(void)
{
    unsigned i = 0u;
    (void)i;
HX_FINITE_BODY
    return 1;
}

static void HX_tune(const double *mp)
{
    unsigned i = 0u, j = 0u;
    (void)i; (void)j; (void)mp;
HX_TUNE_BODY
}

static void HX_defaults(HX_inst *s)
{
    s->P = HX_DEFAULTS;
    memcpy(s->mp, HX_MP0, sizeof s->mp);
    s->u = 0.0; s->y = 0.0; s->time = 0.0;
    s->n = 0; s->carry = 0.0;
    s->mode = 0; s->dirty = 0;
    HX_P_ = &s->P;
    HX_m_init(&s->st);
}

static void HX_retune(HX_inst *s)
{
    HX_P_ = &s->P;
    if (s->dirty) { HX_tune(s->mp); s->dirty = 0; }
}

/* the output for the current input without advancing the memory */
static double HX_peek(HX_inst *s)
{
    HX_m_state copy = s->st;
    HX_P_ = &s->P;
    return HX_m_step(&copy, s->u);
}

static int HX_get(HX_inst *s, unsigned vr, double *v)
{
    if (vr == 0u) *v = s->time;
    else if (vr == 1u) *v = s->u;
    else if (vr == 2u) *v = s->y;
    else if (vr == 3u && HX_DT > 0.0) *v = HX_DT;
    else if (vr == 4u && HX_HAS_PREVIEW) *v = (double)HX_PREVIEW;
    else if (vr >= HX_VR0 && vr < HX_VR0 + HX_NPAR) *v = s->mp[vr - HX_VR0];
    else return 0;
    return 1;
}

/* Setting values is one transaction per Set call: HX_begin keeps the values, HX_set
 * takes each value (0, or a message), HX_commit checks the parameters' rules and derived
 * constants; on any refusal HX_undo puts every value of the call back. */
static void HX_begin(HX_inst *s)
{
    memcpy(s->mp_old, s->mp, sizeof s->mp);
    memset(s->changed, 0, sizeof s->changed);
    s->u_old = s->u;
}

static void HX_undo(HX_inst *s)
{
    memcpy(s->mp, s->mp_old, sizeof s->mp);
    s->u = s->u_old;
    s->dirty = 1;
    if (s->mode >= 2) HX_retune(s);
}

/* 0: taken; else a message for the user, *discard set when the value (not the call) is
 * refused */
static const char *HX_set(HX_inst *s, unsigned vr, double v, int *discard)
{
    *discard = 0;
    if (vr == 1u) {
        if (!(v == v) || v - v != 0.0) {
            *discard = 1;
            snprintf(s->msg, sizeof s->msg, "the input %s must be a finite number, got %g; "
                     "the previous value %.17g is kept and the model's memory is unchanged",
                     HX_IN_NAME, v, s->u_old);
            return s->msg;
        }
        s->u = v;
        return 0;
    }
    if (vr == 3u && HX_DT > 0.0) {
        if (v == HX_DT && s->mode < 2) return 0;
        snprintf(s->msg, sizeof s->msg, "sample_time = %.17g s is fixed at export (%.17g s, "
                 "baked into the model's discretisation); re-export the FMU with another "
                 "--dt to change it", v, HX_DT);
        return s->msg;
    }
    if (vr >= HX_VR0 && vr < HX_VR0 + HX_NPAR) {
        const unsigned k = vr - HX_VR0;
        if (HX_KIND[k] == 0) {
            snprintf(s->msg, sizeof s->msg, "%s is fixed at export; re-export the FMU to "
                     "change it", HX_NAME[k]);
            return s->msg;
        }
        if (HX_KIND[k] == 2 && s->mode >= 2) {
            snprintf(s->msg, sizeof s->msg, "%s is an initial state: it can only be set "
                     "before initialisation (or after a reset)", HX_NAME[k]);
            return s->msg;
        }
        if (!(v == v) || v - v != 0.0) {
            *discard = 1;
            snprintf(s->msg, sizeof s->msg, "%s must be a finite number, got %g; the "
                     "previous value %.17g is kept", HX_NAME[k], v, s->mp_old[k]);
            return s->msg;
        }
        s->mp[k] = v;
        s->changed[k] = 1;
        s->dirty = 1;
        return 0;
    }
    if (vr <= 4u) {
        snprintf(s->msg, sizeof s->msg, "value reference %u (%s) cannot be set", vr,
                 vr == 0u ? "time" : vr == 2u ? HX_OUT_NAME : vr == 4u ? "preview_samples"
                 : "not a variable of this FMU");
        return s->msg;
    }
    snprintf(s->msg, sizeof s->msg, "unknown value reference %u", vr);
    return s->msg;
}

/* 0, or the rule parameter k breaks (its declared limits; increasing with its neighbours) */
static const char *HX_rule(HX_inst *s, unsigned k)
{
    const double v = s->mp[k];
    const int p = HX_PREV[k], q = HX_NEXT[k];
    const char *what = 0;
    double bound = 0.0;
    const char *other = "";
    if (HX_STRICT[k] ? !(v > HX_LO[k]) : !(v >= HX_LO[k])) {
        what = HX_STRICT[k] ? "greater than" : "at least";
        bound = HX_LO[k];
    } else if (!(v <= HX_HI[k])) {
        what = "at most";
        bound = HX_HI[k];
    } else if (p >= 0 && !(v > s->mp[p])) {
        what = "greater than";
        bound = s->mp[p];
        other = HX_NAME[p];
    } else if (q >= 0 && !(v < s->mp[q])) {
        what = "less than";
        bound = s->mp[q];
        other = HX_NAME[q];
    }
    if (!what) return 0;
    snprintf(s->msg, sizeof s->msg, "%s = %.17g is refused: it must be %s %s%s%.17g%s; the "
             "previous value %.17g is kept", HX_NAME[k], v, what, other, *other ? " = " : "",
             bound, *other ? " (the values must increase)" : "", s->mp_old[k]);
    return s->msg;
}

/* 0, or why PI stage rule k is broken: a compensator's PI (the inverse of the model's)
 * inverts an invertible PI only while every slope p0 + p1 + ... + p_j is > 0 */
static const char *HX_slopes(HX_inst *s, unsigned k)
{
    const int a = HX_SLOPES[k][0], w = HX_SLOPES[k][1], n = HX_SLOPES[k][2];
    double slope = s->mp[a];
    int j, touched = s->changed[a];
    for (j = 0; j < n; ++j) touched |= s->changed[w + j];
    if (!touched) return 0;
    for (j = 0; j <= n; ++j) {
        if (j > 0) slope += s->mp[w + j - 1];
        if (!(slope > 0.0)) {
            snprintf(s->msg, sizeof s->msg, "%s .. %s: the slopes of the compensator's PI "
                     "(%s plus the first weights) must stay > 0 for it to invert a PI model, "
                     "but slope %d would be %.17g; the previous values are kept",
                     HX_NAME[a], HX_NAME[w + n - 1], HX_NAME[a], j + 1, slope);
            return s->msg;
        }
    }
    return 0;
}

/* after the values of one Set call: 0, or a message (*discard set) and every value back */
static const char *HX_commit(HX_inst *s, int *discard)
{
    unsigned k;
    *discard = 1;
    for (k = 0; k < HX_NPAR; ++k) {
        const char *err = s->changed[k] ? HX_rule(s, k) : 0;
        if (err) { HX_undo(s); return err; }
    }
    for (k = 0; k < HX_NSLOPES; ++k) {
        const char *err = HX_slopes(s, k);
        if (err) { HX_undo(s); return err; }
    }
    if (s->mode >= 2 && s->dirty) {
        HX_retune(s);
        if (!HX_finite()) {
            HX_undo(s);
            return HX_NOT_FINITE "; the previous values are kept";
        }
    }
    *discard = 0;
    return 0;
}

/* 0, or a message when the parameters set before initialisation are unusable */
static const char *HX_start(HX_inst *s)
{
    HX_retune(s);
    if (!HX_finite()) return HX_NOT_FINITE;
    HX_m_init(&s->st);
    s->y = HX_peek(s);
    s->n = 0; s->carry = 0.0;
    s->mode = 2;
    return 0;
}

/* Run the samples of one communication step [t, t + h]; 0, or a message (and *discard
 * set when the step was not taken and the state is as before it).
 *
 * The FMU counts its own samples and the part of a sample the steps so far held
 * (carry): a step runs the samples whose instants fall inside it, the input held. A step
 * that ends within HX_TOL of a sample instant (an importer adding up its time in floating
 * point, a tiny last step to a stop time) ends on that instant, so no sample runs twice or
 * is skipped; any other step holds its remainder for the next one. Without dynamics each
 * step of positive length is one sample. */
static const char *HX_step(HX_inst *s, double t, double h, int *discard)
{
    long long n = 1, k;
    double carry = s->carry;
    *discard = 0;
    if (!(h >= 0.0) || h - h != 0.0) {
        snprintf(s->msg, sizeof s->msg, "the communication step must be a finite number "
                 "of seconds >= 0, got %.17g s (at t = %.17g s; sample_time = %.17g s)", h,
                 t, HX_DT);
        return s->msg;
    }
    if (HX_DT > 0.0) {
        const double r = carry + h / HX_DT, w = floor(r + 0.5);
        if (r > HX_MAX_SAMPLES) {
            snprintf(s->msg, sizeof s->msg, "a communication step of %.17g s is %.6g sample "
                     "times (sample_time = %.17g s); at most %.0f samples per step, take "
                     "shorter steps", h, r, HX_DT, HX_MAX_SAMPLES);
            return s->msg;
        }
        if (fabs(r - w) <= HX_TOL * (1.0 + 1e-6 * r)) { n = (long long)w; carry = 0.0; }
        else { n = (long long)floor(r); carry = r - (double)n; }
    } else if (h == 0.0) {
        n = 0;
    }
    HX_retune(s);
    {
        const HX_m_state saved = s->st;
        const double y0 = s->y;
        for (k = 0; k < n; ++k) {
            s->y = HX_m_step(&s->st, s->u);
            if (s->y - s->y != 0.0) {
                snprintf(s->msg, sizeof s->msg, "the output %s would be %g at sample %lld "
                         "(input %s = %.17g): beyond what the model's numbers can represent; "
                         "the step is not taken and the model's memory is kept", HX_OUT_NAME,
                         s->y, s->n + k + 1, HX_IN_NAME, s->u);
                s->st = saved;
                s->y = y0;
                *discard = 1;
                return s->msg;
            }
        }
    }
    s->n += n;
    s->carry = carry;
    s->time = t + h;
    return 0;
}
"""

_FMI3 = r"""
#define HX_LOGGER fmi3InstanceEnvironment env; fmi3LogMessageCallback log; int logging;
#include "fmi3Functions.h"
HX_CORE_HERE

static void HX_msg(HX_inst *s, fmi3Status st, const char *what)
{
    if (s->log) s->log(s->env, st, st == fmi3Discard ? "logStatusDiscard" : "logStatusError",
                       what);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                               size_t nCategories, const fmi3String categories[])
{
    (void)nCategories; (void)categories;
    if (!instance) return fmi3Error;
    ((HX_inst *)instance)->logging = loggingOn ? 1 : 0;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
    fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
    fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName,
    fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn; (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
    fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
    fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    HX_inst *s;
    (void)resourcePath; (void)visible; (void)eventModeUsed; (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (!instantiationToken || strcmp(instantiationToken, HX_TOKEN) != 0) {
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
            "instantiation token does not match modelDescription.xml (a different FMU?)");
        return NULL;
    }
    s = (HX_inst *)calloc(1, sizeof *s);
    if (!s) return NULL;
    strncpy(s->name, instanceName ? instanceName : "", sizeof s->name - 1);
    s->env = instanceEnvironment;
    s->log = logMessage;
    s->logging = loggingOn ? 1 : 0;
    HX_defaults(s);
    return s;
}

void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
    fmi3Float64 tolerance, fmi3Float64 startTime, fmi3Boolean stopTimeDefined,
    fmi3Float64 stopTime)
{
    HX_inst *s = (HX_inst *)instance;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!s) return fmi3Error;
    s->time = startTime;
    s->mode = 1;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    const char *err;
    if (!instance) return fmi3Error;
    err = HX_start((HX_inst *)instance);
    if (err) { HX_msg((HX_inst *)instance, fmi3Error, err); return fmi3Error; }
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return instance ? fmi3OK : fmi3Error; }

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    ((HX_inst *)instance)->mode = 3;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    HX_defaults((HX_inst *)instance);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
    size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    HX_inst *s = (HX_inst *)instance;
    size_t k;
    if (!s || nValues != nValueReferences) return fmi3Error;
    for (k = 0; k < nValueReferences; ++k) {
        if (!HX_get(s, valueReferences[k], &values[k])) {
            HX_msg(s, fmi3Error, "fmi3GetFloat64: unknown value reference");
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
    size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    HX_inst *s = (HX_inst *)instance;
    const char *err = 0;
    size_t k;
    int discard = 0;
    if (!s || nValues != nValueReferences) return fmi3Error;
    HX_begin(s);
    for (k = 0; k < nValueReferences && !err; ++k)
        err = HX_set(s, valueReferences[k], values[k], &discard);
    if (err) HX_undo(s);
    else err = HX_commit(s, &discard);
    if (err) {
        HX_msg(s, discard ? fmi3Discard : fmi3Error, err);
        return discard ? fmi3Discard : fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
    fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
    fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
    fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    HX_inst *s = (HX_inst *)instance;
    const char *err;
    int discard;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!s || s->mode != 2) return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    err = HX_step(s, currentCommunicationPoint, communicationStepSize, &discard);
    if (lastSuccessfulTime) *lastSuccessfulTime = err ? currentCommunicationPoint : s->time;
    if (err) {
        HX_msg(s, discard ? fmi3Discard : fmi3Error, err);
        return discard ? fmi3Discard : fmi3Error;
    }
    return fmi3OK;
}
"""

_FMI2 = r"""
#define HX_LOGGER const fmi2CallbackFunctions *cb; int logging;
#include "fmi2Functions.h"
HX_CORE_HERE

/* the message as the format itself ('%' doubled, no arguments): a logger that does not
 * format (one written in another language) still shows it */
static void HX_msg(HX_inst *s, fmi2Status st, const char *what)
{
    char fmt[2 * sizeof s->msg];
    size_t i = 0;
    if (!s->cb || !s->cb->logger) return;
    for (; *what && i + 2 < sizeof fmt; ++what) {
        if (*what == '%') fmt[i++] = '%';
        fmt[i++] = *what;
    }
    fmt[i] = '\0';
    s->cb->logger(s->cb->componentEnvironment, s->name, st,
                  st == fmi2Discard ? "logStatusDiscard" : "logStatusError", fmt);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories; (void)categories;
    if (!c) return fmi2Error;
    ((HX_inst *)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
    fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
    fmi2Boolean visible, fmi2Boolean loggingOn)
{
    HX_inst *s;
    (void)fmuResourceLocation; (void)visible;
    if (fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, HX_TOKEN) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                "logStatusError", "%s", fmuType != fmi2CoSimulation
                ? "this FMU supports co-simulation only"
                : "GUID does not match modelDescription.xml (a different FMU?)");
        return NULL;
    }
    s = (HX_inst *)calloc(1, sizeof *s);
    if (!s) return NULL;
    strncpy(s->name, instanceName ? instanceName : "", sizeof s->name - 1);
    s->cb = functions;
    s->logging = loggingOn ? 1 : 0;
    HX_defaults(s);
    return s;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
    fmi2Real tolerance, fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    HX_inst *s = (HX_inst *)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!s) return fmi2Error;
    s->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    if (!c) return fmi2Error;
    ((HX_inst *)c)->mode = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    const char *err;
    if (!c) return fmi2Error;
    err = HX_start((HX_inst *)c);
    if (err) { HX_msg((HX_inst *)c, fmi2Error, err); return fmi2Error; }
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    if (!c) return fmi2Error;
    ((HX_inst *)c)->mode = 3;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (!c) return fmi2Error;
    HX_defaults((HX_inst *)c);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    HX_inst *s = (HX_inst *)c;
    size_t k;
    if (!s) return fmi2Error;
    for (k = 0; k < nvr; ++k) {
        if (vr[k] == 0u || !HX_get(s, vr[k], &value[k])) {
            HX_msg(s, fmi2Error, "fmi2GetReal: unknown value reference");
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    HX_inst *s = (HX_inst *)c;
    const char *err = 0;
    size_t k;
    int discard = 0;
    if (!s) return fmi2Error;
    HX_begin(s);
    for (k = 0; k < nvr && !err; ++k)
        err = HX_set(s, vr[k], value[k], &discard);
    if (err) HX_undo(s);
    else err = HX_commit(s, &discard);
    if (err) {
        HX_msg(s, discard ? fmi2Discard : fmi2Error, err);
        return discard ? fmi2Discard : fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
    fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint)
{
    HX_inst *s = (HX_inst *)c;
    const char *err;
    int discard;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!s || s->mode != 2) return fmi2Error;
    err = HX_step(s, currentCommunicationPoint, communicationStepSize, &discard);
    if (err) {
        HX_msg(s, discard ? fmi2Discard : fmi2Error, err);
        return discard ? fmi2Discard : fmi2Error;
    }
    return fmi2OK;
}

/* after a discarded step the master asks how far the FMU got: the end of the last step
 * taken (a discarded step runs no sample) */
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    if (!c || !value || s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = ((HX_inst *)c)->time;
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (!c || !value || s != fmi2Terminated) return fmi2Discard;
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s;
    if (!c || !value) return fmi2Error;
    *value = fmi2OK;
    return fmi2OK;
}
"""

_IMPLEMENTED = {
    3: {"fmi3GetVersion", "fmi3SetDebugLogging", "fmi3InstantiateModelExchange",
        "fmi3InstantiateCoSimulation", "fmi3InstantiateScheduledExecution", "fmi3FreeInstance",
        "fmi3EnterInitializationMode", "fmi3ExitInitializationMode", "fmi3EnterStepMode",
        "fmi3Terminate", "fmi3Reset", "fmi3GetFloat64", "fmi3SetFloat64", "fmi3DoStep"},
    2: {"fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
        "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
        "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal",
        "fmi2SetReal", "fmi2DoStep", "fmi2GetStatus", "fmi2GetRealStatus",
        "fmi2GetBooleanStatus"},
}
_TYPEDEF = re.compile(r"typedef\s+(fmi[23]Status)\s+(fmi[23]\w+)TYPE\s*\(([^)]*)\)\s*;")
_IDENT = re.compile(r"[A-Za-z_]\w*")


def _stubs(version: int, headers: Path) -> list[str]:
    """A definition returning ``fmi<v>Error`` for every status function of the FMI headers
    (in folder ``headers``) that this FMU does not provide (prototypes read from them)."""
    text = (headers / f"fmi{version}FunctionTypes.h").read_text(errors="replace")
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.DOTALL)
    text = re.sub(r"//[^\n]*", " ", text)
    out = []
    for status, fn, params in _TYPEDEF.findall(text):
        if fn in _IMPLEMENTED[version]:
            continue
        decls, names = [], []
        plist = [p.strip() for p in " ".join(params.split()).split(",")]
        for i, p in enumerate(plist):
            if p in ("", "void"):
                continue
            idents = [t for t in _IDENT.findall(p) if t not in ("const", "struct", "unsigned")]
            if len(idents) < 2:  # unnamed parameter: name it
                p = p.replace("[]", f" p{i}[]") if "[]" in p else f"{p} p{i}"
                idents.append(f"p{i}")
            decls.append(p)
            names.append(idents[-1])
        body = " ".join(f"(void){n};" for n in names)
        out.append(f"{status} {fn}({', '.join(decls) or 'void'})\n"
                   f"{{ {body} return {status[:4]}Error; }}")
    return out


def fmu_c_source(code: FmuCode, headers: Path) -> str:
    """The FMU's whole C99 source (``@TOKEN@`` stands for the instantiation token).

    Parameters
    ----------
    code : FmuCode
    headers : Path
        Folder of the FMI headers (``fmi<v>FunctionTypes.h``): the stubs follow them.
    """
    hx = code.ident
    finite = [f"    if (!isfinite({cid})) return 0;" if size is None else
              f"    for (i = 0; i < {size}u; ++i) if (!isfinite({cid}[i])) return 0;"
              for ctype, cid, size, _ in code.constants if ctype == "double"]
    struct = [f"    {ctype} {cid}{'' if size is None else f'[{size}]'};"
              for ctype, cid, size, _ in code.constants] or ["    int unused_;"]
    defaults = [f"    {init}," for *_, init in code.constants] or ["    0,"]
    nmp = max(len(code.parameters), 1)
    core = _CORE.replace("HX_TUNE_BODY", "\n".join(f"    {line}" for line in code.tune))
    core = core.replace("HX_FINITE_BODY", "\n".join(finite))
    wrapper = (_FMI3 if code.fmi_version == 3 else _FMI2).replace("HX_CORE_HERE", core)
    mp_init = ", ".join(c_double(v) for v in code.parameters) or "0.0"
    limits = code.limits or tuple((None, None, False, -1, -1) for _ in code.parameters)
    names = code.names or tuple(f"parameter {code.first_vr + k}"
                                for k in range(len(code.parameters)))

    def bound(v: float | None, missing: str) -> str:
        return missing if v is None else c_double(v)

    rules = [
        f"static const double {hx}_LO[{nmp}] = "
        f"{{{', '.join(bound(lim[0], '-HUGE_VAL') for lim in limits) or '0.0'}}};",
        f"static const double {hx}_HI[{nmp}] = "
        f"{{{', '.join(bound(lim[1], 'HUGE_VAL') for lim in limits) or '0.0'}}};",
        f"static const unsigned char {hx}_STRICT[{nmp}] = "
        f"{{{', '.join(str(int(lim[2])) for lim in limits) or '0'}}};",
        f"static const int {hx}_PREV[{nmp}] = "
        f"{{{', '.join(str(lim[3]) for lim in limits) or '-1'}}};",
        f"static const int {hx}_NEXT[{nmp}] = "
        f"{{{', '.join(str(lim[4]) for lim in limits) or '-1'}}};",
        f"static const char *const {hx}_NAME[{nmp}] = {{",
        *(f"    {c_string(n)}," for n in names or ("",)),
        "};",
    ]
    kind_init = ", ".join(str(k) for k in code.kinds) or "0"
    v = code.fmi_version
    lines = [
        f"/* {hx}.c: FMI {v}.0 co-simulation FMU generated by hysteresis-explorer",
        " * (core/export_fmu.py) from the C99 code of core/export_c.py. One translation unit;",
        f" * build: cc -std=c99 -O2 -shared -fPIC -I<FMI {v} headers> {hx}.c -lm */",
        "#include <math.h>",
        "#include <stddef.h>",
        "#include <stdio.h>",
        "#include <stdlib.h>",
        "#include <string.h>",
        "",
        _TLS,
        "",
        f'#define {hx}_TOKEN "@TOKEN@"',
        f"#define {hx}_DT {c_double(code.dt) if code.dt is not None else '0.0'}",
        f"#define {hx}_PREVIEW {code.preview}",
        f"#define {hx}_HAS_PREVIEW {1 if code.inverse else 0}",
        f"#define {hx}_VR0 {code.first_vr}u",
        f"#define {hx}_NPAR {len(code.parameters)}u",
        f"#define {hx}_NMP {nmp}",
        "/* a step ending this close to a sample instant (in samples) ends on it */",
        f"#define {hx}_TOL 1e-6",
        f"#define {hx}_MAX_SAMPLES 1e9",
        "",
        "/* every constant of every stage: the run-time (tunable) copy of the C export's",
        " * static constants; the model code reads them through the thread-local pointer */",
        "typedef struct {", *struct, f"}} {hx}_params;",
        f"static const {hx}_params {hx}_DEFAULTS = {{", *defaults, "};",
        f"static HYST_TLS {hx}_params *{hx}_P_;",
        f"/* model parameters (value reference {code.first_vr} + index), their kinds: "
        "1 tunable, 2 initial state (fixed), 0 fixed at export */",
        f"static const double {hx}_MP0[{nmp}] = {{{mp_init}}};",
        f"static const unsigned char {hx}_KIND[{nmp}] = {{{kind_init}}};",
        "/* their rules: limits, and the neighbours an increasing field keeps them between */",
        *rules,
        f"#define {hx}_NSLOPES {len(code.slopes)}u",
        f"static const int {hx}_SLOPES[{max(len(code.slopes), 1)}][3] = "
        f"{{{', '.join(f'{{{a}, {w}, {n}}}' for a, w, n in code.slopes) or '{0, 0, 0}'}}};",
        f"#define {hx}_IN_NAME {c_string(code.ports[0])}",
        f"#define {hx}_OUT_NAME {c_string(code.ports[1])}",
        "",
        code.header,
        "",
        code.body,
        "",
        wrapper.replace("HX", hx),
        "",
        "/* ---- the rest of the FMI API: not provided by this co-simulation FMU */",
        *_stubs(v, headers),
        "",
    ]
    return "\n".join(lines)
