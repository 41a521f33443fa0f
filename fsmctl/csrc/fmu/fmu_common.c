/*
 * fsmctl FMUs: the FMI 2.0 co-simulation interface, common to the plant and controller FMUs.
 * Copied into every FMU by fsmctl.export.fmu (do not edit the copy); the model is in the FMU's other sources
 * (fmu_model.h), its variables in fmu_variables.h (written with modelDescription.xml from one table).
 *
 * What is supported: co-simulation only; one doStep at a time (no asynchronous steps, no rollback, no FMU state
 * get/set, no directional derivatives, no input derivatives); Real and Integer variables (no Boolean or String
 * variables: their get/set succeed only for an empty list).  Errors are reported through the logger callback
 * (category "logStatusError") with a one-line reason, and the instance then refuses every call but fmi2FreeInstance.
 */
#include <string.h>

#include "fmi2Functions.h"
#include "fmu_model.h"
#define FSMFMU_TABLES
#include "fmu_variables.h"

enum { ACCESS_NONE = 0, ACCESS_PARAMETER = 1, ACCESS_INPUT = 2 };
enum { INSTANTIATED = 1, INITIALIZATION = 2, STEPPING = 3, TERMINATED = 4, FAILED = 5 };

static const fmi2ValueReference n_real = FSMFMU_N_REAL, n_integer = FSMFMU_N_INTEGER; /* (no constant compare) */

typedef struct {
  fmi2CallbackFunctions callbacks;
  char name[64];
  int state;
  int logging;
  double t0, t;
  double r[FSMFMU_N_REAL_ALLOC];
  int integers[FSMFMU_N_INTEGER_ALLOC];
  void *model;
} instance;

static void log_message(instance *c, fmi2Status status, const char *category, const char *message) {
  if (c->callbacks.logger && (status != fmi2OK || c->logging))
    c->callbacks.logger(c->callbacks.componentEnvironment, c->name, status, category, "%s", message);
}

static fmi2Status fail(instance *c, const char *message) {
  c->state = FAILED;
  log_message(c, fmi2Error, "logStatusError", message);
  return fmi2Error;
}

static fmi2Status refuse(instance *c, const char *message) {
  log_message(c, fmi2Error, "logStatusError", message);
  return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  instance *c;
  (void)fmuResourceLocation;
  (void)visible;
  if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
  if (fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, FSMFMU_GUID) != 0) {
    if (functions->logger)
      functions->logger(functions->componentEnvironment, instanceName ? instanceName : "", fmi2Error,
                        "logStatusError", "%s", "not this FMU's GUID, or not co-simulation");
    return NULL;
  }
  c = (instance *)functions->allocateMemory(1, sizeof(instance));
  if (!c) return NULL;
  c->model = functions->allocateMemory(1, fsmfmu_model_bytes());
  if (!c->model) {
    functions->freeMemory(c);
    return NULL;
  }
  c->callbacks = *functions;
  strncpy(c->name, instanceName ? instanceName : "", sizeof c->name - 1);
  c->name[sizeof c->name - 1] = 0;
  c->logging = loggingOn ? 1 : 0;
  c->state = INSTANTIATED;
  c->t0 = c->t = 0;
  memcpy(c->r, fsmfmu_real_start, sizeof c->r);
  memcpy(c->integers, fsmfmu_integer_start, sizeof c->integers);
  return c;
}

void fmi2FreeInstance(fmi2Component component) {
  instance *c = (instance *)component;
  if (!c) return;
  c->callbacks.freeMemory(c->model);
  c->callbacks.freeMemory(c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  instance *c = (instance *)component;
  (void)nCategories;
  (void)categories;
  c->logging = loggingOn ? 1 : 0;
  return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  instance *c = (instance *)component;
  (void)toleranceDefined;
  (void)tolerance;
  (void)stopTimeDefined;
  (void)stopTime;
  if (c->state != INSTANTIATED) return refuse(c, "fmi2SetupExperiment: only after fmi2Instantiate");
  if (!(startTime - startTime == 0)) return refuse(c, "fmi2SetupExperiment: the start time must be finite");
  c->t0 = c->t = startTime;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
  instance *c = (instance *)component;
  if (c->state != INSTANTIATED) return refuse(c, "fmi2EnterInitializationMode: only after fmi2Instantiate");
  c->state = INITIALIZATION;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
  instance *c = (instance *)component;
  const char *why = "";
  if (c->state != INITIALIZATION) return refuse(c, "fmi2ExitInitializationMode: not in initialization mode");
  if (fsmfmu_model_init(c->model, c->r, c->integers, c->t0, &why)) return fail(c, why);
  c->state = STEPPING;
  return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
  instance *c = (instance *)component;
  c->state = TERMINATED;
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
  instance *c = (instance *)component;
  c->state = INSTANTIATED;
  c->t0 = c->t = 0;
  memcpy(c->r, fsmfmu_real_start, sizeof c->r);
  memcpy(c->integers, fsmfmu_integer_start, sizeof c->integers);
  return fmi2OK;
}

static int settable(const instance *c, int access) {
  if (access == ACCESS_INPUT) return c->state == INSTANTIATED || c->state == INITIALIZATION || c->state == STEPPING;
  if (access == ACCESS_PARAMETER) return c->state == INSTANTIATED || c->state == INITIALIZATION;
  return 0;
}

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  instance *c = (instance *)component;
  size_t k;
  if (c->state == FAILED) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] >= n_real) return refuse(c, "fmi2GetReal: unknown value reference");
    value[k] = c->r[vr[k]];
  }
  return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
  instance *c = (instance *)component;
  size_t k;
  if (c->state == FAILED) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] >= n_integer) return refuse(c, "fmi2GetInteger: unknown value reference");
    value[k] = c->integers[vr[k]];
  }
  return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return nvr ? refuse((instance *)component, "fmi2GetBoolean: this FMU has no Boolean variables") : fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  (void)vr;
  (void)value;
  return nvr ? refuse((instance *)component, "fmi2GetString: this FMU has no String variables") : fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
  instance *c = (instance *)component;
  size_t k;
  if (c->state == FAILED) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] >= n_real) return refuse(c, "fmi2SetReal: unknown value reference");
    if (!settable(c, fsmfmu_real_access[vr[k]]))
      return refuse(c, "fmi2SetReal: not settable now (an output, or a parameter after initialization)");
  }
  for (k = 0; k < nvr; ++k) c->r[vr[k]] = value[k];
  return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
  instance *c = (instance *)component;
  size_t k;
  if (c->state == FAILED) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] >= n_integer) return refuse(c, "fmi2SetInteger: unknown value reference");
    if (!settable(c, fsmfmu_integer_access[vr[k]]))
      return refuse(c, "fmi2SetInteger: not settable now (a parameter after initialization)");
  }
  for (k = 0; k < nvr; ++k) c->integers[vr[k]] = value[k];
  return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return nvr ? refuse((instance *)component, "fmi2SetBoolean: this FMU has no Boolean variables") : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
  (void)vr;
  (void)value;
  return nvr ? refuse((instance *)component, "fmi2SetString: this FMU has no String variables") : fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *state) {
  (void)state;
  return refuse((instance *)component, "fmi2GetFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate state) {
  (void)state;
  return refuse((instance *)component, "fmi2SetFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate *state) {
  (void)state;
  return refuse((instance *)component, "fmi2FreeFMUstate: not supported (canGetAndSetFMUstate is false)");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate state, size_t *size) {
  (void)state;
  (void)size;
  return refuse((instance *)component, "fmi2SerializedFMUstateSize: not supported");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
  (void)state;
  (void)bytes;
  (void)size;
  return refuse((instance *)component, "fmi2SerializeFMUstate: not supported");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
  (void)bytes;
  (void)size;
  (void)state;
  return refuse((instance *)component, "fmi2DeSerializeFMUstate: not supported");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component component, const fmi2ValueReference vUnknown[],
                                        size_t nUnknown, const fmi2ValueReference vKnown[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  (void)vUnknown;
  (void)nUnknown;
  (void)vKnown;
  (void)nKnown;
  (void)dvKnown;
  (void)dvUnknown;
  return refuse((instance *)component, "fmi2GetDirectionalDerivative: not supported");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return refuse((instance *)component, "fmi2SetRealInputDerivatives: not supported (inputs are held)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return refuse((instance *)component, "fmi2GetRealOutputDerivatives: not supported");
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  instance *c = (instance *)component;
  const char *why = "";
  (void)noSetFMUStatePriorToCurrentPoint;
  if (c->state != STEPPING) return refuse(c, "fmi2DoStep: only after fmi2ExitInitializationMode");
  if (fsmfmu_model_step(c->model, c->r, c->integers, currentCommunicationPoint, communicationStepSize, &why))
    return fail(c, why);
  c->t = currentCommunicationPoint + communicationStepSize;
  return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component component) {
  return refuse((instance *)component, "fmi2CancelStep: steps are synchronous");
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status *value) {
  (void)s;
  (void)value;
  return refuse((instance *)component, "fmi2GetStatus: steps are synchronous");
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real *value) {
  instance *c = (instance *)component;
  if (s != fmi2LastSuccessfulTime) return refuse(c, "fmi2GetRealStatus: only fmi2LastSuccessfulTime");
  *value = c->t;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s, fmi2Integer *value) {
  (void)s;
  (void)value;
  return refuse((instance *)component, "fmi2GetIntegerStatus: steps are synchronous");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s, fmi2Boolean *value) {
  (void)s;
  (void)value;
  return refuse((instance *)component, "fmi2GetBooleanStatus: steps are synchronous");
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s, fmi2String *value) {
  (void)s;
  (void)value;
  return refuse((instance *)component, "fmi2GetStringStatus: steps are synchronous");
}
