/* The analysis through libmdr_c, from C: each request the service's reference wrote
 * (DIR/analysis_K.request.pb, K the mdr_analysis number) is run by mdr_analysis_run and its
 * answer written to DIR/analysis_K.library.pb, which capi_service_reference compare_analysis
 * checks against the service's. The fit's progress is counted through the callback. */
#include <mdr/mdr.h>
#include <stdio.h>
#include <stdlib.h>

static unsigned char* ReadFile(const char* path, size_t* size) {
  FILE* file = fopen(path, "rb");
  unsigned char* bytes = NULL;
  long length;
  if (file == NULL) return NULL;
  if (fseek(file, 0, SEEK_END) == 0 && (length = ftell(file)) >= 0 &&
      fseek(file, 0, SEEK_SET) == 0) {
    bytes = malloc((size_t)length + 1);
    if (bytes != NULL && fread(bytes, 1, (size_t)length, file) != (size_t)length) {
      free(bytes);
      bytes = NULL;
    }
    *size = (size_t)length;
  }
  fclose(file);
  return bytes;
}

static int CountProgress(const void* progress, size_t size, void* user) {
  (void)progress;
  if (size > 0) ++*(int*)user;
  return 0; /* go on */
}

int main(int argc, char** argv) {
  static const int kAnalyses[] = {MDR_ANALYZE_LOOPS, MDR_FIT_LOOPS, MDR_FRETTING_MAP, MDR_BACKBONE};
  char path[4096];
  int progress_calls = 0;
  size_t i;
  if (argc != 2) {
    fprintf(stderr, "usage: %s DIR\n", argv[0]);
    return 2;
  }
  for (i = 0; i < sizeof kAnalyses / sizeof kAnalyses[0]; ++i) {
    const int k = kAnalyses[i];
    size_t size = 0;
    unsigned char* request;
    mdr_buffer* response = NULL;
    FILE* out;
    snprintf(path, sizeof path, "%s/analysis_%d.request.pb", argv[1], k);
    request = ReadFile(path, &size);
    if (request == NULL) {
      fprintf(stderr, "%s: cannot read\n", path);
      return 1;
    }
    if (mdr_analysis_run(k, MDR_ENCODING_PROTO, request, size, CountProgress, &progress_calls,
                         &response) != MDR_OK) {
      fprintf(stderr, "analysis %d: %s [%s]\n", k, mdr_last_error_message(),
              mdr_last_error_field());
      return 1;
    }
    free(request);
    snprintf(path, sizeof path, "%s/analysis_%d.library.pb", argv[1], k);
    out = fopen(path, "wb");
    if (out == NULL ||
        fwrite(mdr_buffer_data(response), 1, mdr_buffer_size(response), out) !=
            mdr_buffer_size(response) ||
        fclose(out) != 0) {
      fprintf(stderr, "%s: cannot write\n", path);
      return 1;
    }
    mdr_buffer_destroy(response);
  }
  if (progress_calls == 0) {
    fprintf(stderr, "the fit reported no progress\n");
    return 1;
  }
  printf("4 analyses answered; the fit reported %d iterations\n", progress_calls);
  return 0;
}
