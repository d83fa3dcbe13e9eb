/**
 * @file glovepose_eval.h
 * @brief glovepose's offline evaluation for C (and Python's glovepose.evaluate): a model file scored
 * on a dataset file, the report `glovepose eval --json` prints. Its own shared library,
 * glovepose_eval, beside glovepose_c: engines ship glovepose_c alone, which holds loading and the
 * per-frame calls and none of the training or simulator code this one needs.
 *
 * Pure C (C89 with <stdint.h>, or C99 and later), like glovepose_c.h, whose result codes
 * (glovepose_result, GLOVEPOSE_ERROR_*) it uses; it calls no function of glovepose_c, so a program
 * links only this library for it. After a negative code, glovepose_eval_last_error() on the same
 * thread says what went wrong (this library's own message buffer; glovepose_last_error() is
 * glovepose_c's). No function lets an exception out.
 */
#ifndef GLOVEPOSE_EVAL_H
#define GLOVEPOSE_EVAL_H

#include "glovepose_c.h"

/** @brief Marks a public symbol of glovepose_eval (built with hidden visibility). */
#if defined(_WIN32)
#  if defined(GLOVEPOSE_EVAL_BUILDING)
#    define GLOVEPOSE_EVAL_API __declspec(dllexport)
#  else
#    define GLOVEPOSE_EVAL_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__) || defined(__clang__)
#  define GLOVEPOSE_EVAL_API __attribute__((visibility("default")))
#else
#  define GLOVEPOSE_EVAL_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/**
 * @brief Scores a model file on a dataset file (glovepose simulate or import): what
 * `glovepose eval --json` prints (train::evaluate and its to_json in the C++ library).
 * @param model_path the .safetensors model file.
 * @param dataset_path the dataset file.
 * @param options_json NULL or "{}" for the defaults, or a JSON object with any of: "subjects",
 * "exclude_subjects", "sessions", "gloves" (arrays of ids >= 0), "stride" (>= 1), "calibration_mode"
 * ("none", "training", "onthefly" or "guided"; default the model's), "replay_rows" (true: replay the
 * raw rows through the estimator's readout), "mean_window" (>= 1, with replay_rows), "contact"
 * (true: the contact stage before scoring), "threads" (>= 0; 0: all cores), "weights" ("f32",
 * "f16", "bf16" or "fixed16": how the network holds its weights, as glovepose_model_load's
 * weight_storage; the report's "weights"), "glove" (a glove description file's path: refused unless
 * it is the model's glove).
 * @param out_json receives the report, NUL-terminated UTF-8 JSON, owned by the library and valid on
 * this thread until its next glovepose_evaluate call (NULL on failure).
 * @return GLOVEPOSE_OK, or GLOVEPOSE_ERROR_FILE_NOT_FOUND / _INVALID_FILE (a file, or data the model
 * cannot score) / _INVALID_ARGUMENT (the options) / _OUT_OF_MEMORY, with a message
 * (glovepose_eval_last_error).
 */
GLOVEPOSE_EVAL_API glovepose_result glovepose_evaluate(const char* model_path, const char* dataset_path, const char* options_json,
                                                       const char** out_json) GLOVEPOSE_C_NOEXCEPT;

/**
 * @brief The message of this thread's last failing glovepose_evaluate: a per-thread buffer owned by
 * the library, valid until the next failing call on the same thread ("" before any).
 */
GLOVEPOSE_EVAL_API const char* glovepose_eval_last_error(void) GLOVEPOSE_C_NOEXCEPT;

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* GLOVEPOSE_EVAL_H */
