/*
 * fsmctl FMUs: what a model (the plant, a controller) gives the common FMI 2.0 co-simulation layer (fmu_common.c).
 * Copied into every FMU by fsmctl.export.fmu (do not edit the copy).
 *
 * The FMU's variables are two arrays indexed by value reference: the Reals and the Integers (fmu_variables.h,
 * written by fsmctl.export.fmu from the same table as modelDescription.xml: their start values, which ones may be
 * set when, and the first value reference of each block as FSMFMU_VR_<BLOCK>).  The model reads its parameters and
 * inputs there and writes its outputs there.
 */
#ifndef FSMCTL_FMU_MODEL_H
#define FSMCTL_FMU_MODEL_H

#include <stddef.h>

/* bytes of the model's private state (allocated by the importer's allocateMemory) */
size_t fsmfmu_model_bytes(void);

/* at fmi2ExitInitializationMode: check the parameters, start the model at t0, write the initial outputs into r.
 * Returns 0, else non-zero with *why a one-line reason. */
int fsmfmu_model_init(void *model, double *r, const int *integers, double t0, const char **why);

/* fmi2DoStep(t, h): advance from t to t + h with the inputs in r, write the outputs into r.
 * Returns 0, else non-zero with *why a one-line reason. */
int fsmfmu_model_step(void *model, double *r, const int *integers, double t, double h, const char **why);

#endif /* FSMCTL_FMU_MODEL_H */
