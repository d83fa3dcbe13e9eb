/* glovepose_eval from C89, linked with that library alone (not glovepose_c): the header compiles
   with -Wpedantic -Werror, and the error paths answer with glovepose_c.h's codes and a message in
   glovepose_eval_last_error(). A whole evaluation is python/tests/test_evaluate.py's (against
   `glovepose eval --json`).
   Usage: capi_eval_c MODEL MISSING_FILE */
#include <glovepose_eval.h>

#include <stdio.h>
#include <string.h>

static int failures = 0;

static void check(int ok, const char* what) {
  if (!ok) {
    fprintf(stderr, "FAIL: %s (last error: \"%s\")\n", what, glovepose_eval_last_error());
    ++failures;
  }
}

int main(int argc, char** argv) {
  const char* json = "untouched";
  const char* model;
  const char* missing;
  if (argc != 3) {
    fprintf(stderr, "usage: capi_eval_c MODEL MISSING_FILE\n");
    return 2;
  }
  model = argv[1];
  missing = argv[2];

  check(glovepose_eval_last_error() != NULL && glovepose_eval_last_error()[0] == '\0', "no message before a failure");

  check(glovepose_evaluate(model, model, NULL, NULL) == GLOVEPOSE_ERROR_INVALID_ARGUMENT, "a NULL out_json is refused");
  check(strstr(glovepose_eval_last_error(), "glovepose_evaluate: out_json is NULL") != NULL, "the message names out_json");

  check(glovepose_evaluate(NULL, model, NULL, &json) == GLOVEPOSE_ERROR_INVALID_ARGUMENT, "a NULL model path is refused");
  check(json == NULL, "out_json is NULL after a failure");
  check(strstr(glovepose_eval_last_error(), "model_path or dataset_path is NULL") != NULL, "the message names the paths");

  json = "untouched";
  check(glovepose_evaluate(missing, missing, "{}", &json) == GLOVEPOSE_ERROR_FILE_NOT_FOUND, "a missing model file: not found");
  check(json == NULL, "out_json is NULL after a missing file");
  check(strstr(glovepose_eval_last_error(), missing) != NULL, "the message names the missing model file");

  /* The model loads; the dataset is the one missing. */
  check(glovepose_evaluate(model, missing, "{}", &json) == GLOVEPOSE_ERROR_FILE_NOT_FOUND, "a missing dataset file: not found");
  check(strstr(glovepose_eval_last_error(), missing) != NULL, "the message names the missing dataset file");

  /* A model file given as the dataset: read, and refused as a dataset. */
  check(glovepose_evaluate(model, model, "{}", &json) == GLOVEPOSE_ERROR_INVALID_FILE, "a model file is not a dataset");
  check(glovepose_eval_last_error()[0] != '\0', "with a message");

  if (failures == 0) printf("PASS: glovepose_eval's error paths from C89\n");
  return failures == 0 ? 0 : 1;
}
