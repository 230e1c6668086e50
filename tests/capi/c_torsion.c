/* A torsional contact in C on libmdr_c (mdr_torsion): the history of the service's torsional
 * session, stepped one call at a time, printing what tests/capi/service_reference.cc writes for
 * the service (torsion_reference.txt), which the test compares byte for byte; then the final
 * snapshot for the service to import.
 *
 *   c_torsion REFERENCE_DIR SCENE_FILE SNAPSHOT_OUT
 *
 * The contact is created from the scene file's text, and must equal the one created from the
 * serialized Scene (torsion_scene.pb); after the history it is restored from the service's
 * snapshot (torsion_snapshot.pb) and repeats the rest. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mdr/mdr.h"

enum { kRestoreAt = 50, kMaxSteps = 1024, kRadii = 10 }; /* kRestoreAt: kTorsionRestoreAt */

typedef struct {
  int normal_control, twist_control;
  double normal_value, twist_value;
} history_step;

static double FromHex(const char* text) {
  uint64_t bits = strtoull(text, NULL, 16);
  double value;
  memcpy(&value, &bits, sizeof value);
  return value;
}

static void PrintHex(double value) {
  uint64_t bits;
  memcpy(&bits, &value, sizeof bits);
  printf(" %016" PRIX64, bits);
}

static int Fail(const char* what) {
  fprintf(stderr, "c_torsion: %s: error %d, field '%s': %s\n", what, mdr_last_error_code(),
          mdr_last_error_field(), mdr_last_error_message());
  return 1;
}

static char* ReadFile(const char* path, size_t* size) {
  FILE* file = fopen(path, "rb");
  if (file == NULL) return NULL;
  fseek(file, 0, SEEK_END);
  long length = ftell(file);
  fseek(file, 0, SEEK_SET);
  char* bytes = malloc((size_t)length + 1);
  *size = fread(bytes, 1, (size_t)length, file);
  bytes[*size] = '\0';
  fclose(file);
  return bytes;
}

static char* ReadReference(const char* dir, const char* name, size_t* size) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return ReadFile(path, size);
}

static int ReadHistory(const char* dir, history_step* steps) {
  size_t size;
  char* text = ReadReference(dir, "torsion_history.txt", &size);
  if (text == NULL) return -1;
  int count = 0, used;
  char normal[32], twist[32];
  const char* line = text;
  while (count < kMaxSteps && sscanf(line, "%d %31s %d %31s%n", &steps[count].normal_control,
                                     normal, &steps[count].twist_control, twist, &used) == 4) {
    steps[count].normal_value = FromHex(normal);
    steps[count].twist_value = FromHex(twist);
    ++count;
    line += used;
  }
  free(text);
  return count;
}

static int RunSteps(mdr_torsion* torsion, const history_step* steps, int first, int last) {
  for (int i = first; i < last; ++i) {
    mdr_step_report report;
    mdr_torsional_state state;
    if (mdr_torsion_step(torsion, steps[i].normal_control, steps[i].normal_value,
                         steps[i].twist_control, steps[i].twist_value, &report) != MDR_OK ||
        mdr_torsion_state(torsion, &state) != MDR_OK) {
      fprintf(stderr, "c_torsion: step %d\n", i);
      return Fail("mdr_torsion_step");
    }
    if (report.dissipated != state.last_step_dissipation || report.substeps != 1) {
      fprintf(stderr, "c_torsion: step %d: the report differs from the state\n", i);
      return 1;
    }
    printf("S");
    PrintHex(state.depth);
    PrintHex(state.contact_radius);
    PrintHex(state.normal_force);
    PrintHex(state.twist);
    PrintHex(state.twisting_moment);
    PrintHex(state.full_slip_moment);
    PrintHex(state.dissipated_energy);
    PrintHex(report.dissipated);
    PrintHex(state.friction_limit);
    printf(" %" PRIu64 " %" PRIu64 "\n", state.applied_steps, state.memory_pieces);
  }
  return 0;
}

static int PrintFinals(const mdr_torsion* torsion) {
  double positive, negative;
  if (mdr_torsion_stiffness(torsion, &positive, &negative) != MDR_OK) return Fail("stiffness");
  printf("K");
  PrintHex(positive);
  PrintHex(negative);
  printf("\n");
  size_t count;
  /* Ask for the size first, as a caller without a bound would. */
  if (mdr_torsion_slip_intervals(torsion, NULL, NULL, NULL, 0, &count) != MDR_OUT_OF_RANGE &&
      count > 0) {
    return Fail("slip_intervals without room");
  }
  double* r_begin = malloc((count + 1) * sizeof(double));
  double* r_end = malloc((count + 1) * sizeof(double));
  int32_t* direction = malloc((count + 1) * sizeof(int32_t));
  if (mdr_torsion_slip_intervals(torsion, r_begin, r_end, direction, count, &count) != MDR_OK) {
    return Fail("slip_intervals");
  }
  printf("L %zu\n", count);
  for (size_t i = 0; i < count; ++i) {
    printf("I");
    PrintHex(r_begin[i]);
    PrintHex(r_end[i]);
    printf(" %d\n", (int)direction[i]);
  }
  free(r_begin);
  free(r_end);
  free(direction);
  mdr_torsional_state state;
  if (mdr_torsion_state(torsion, &state) != MDR_OK) return Fail("state");
  double radii[kRadii], tau[kRadii], difference[kRadii];
  for (int k = 0; k < kRadii; ++k) radii[k] = state.contact_radius * k / 8;
  if (mdr_torsion_tractions(torsion, radii, kRadii, tau, difference, kRadii) != MDR_OK) {
    return Fail("tractions");
  }
  for (int k = 0; k < kRadii; ++k) {
    printf("T");
    PrintHex(tau[k]);
    PrintHex(difference[k]);
    printf("\n");
  }
  double stored;
  if (mdr_torsion_stored_energy(torsion, &stored) != MDR_OK) return Fail("stored_energy");
  printf("E");
  PrintHex(stored);
  printf("\n");
  return 0;
}

/* The snapshot's bytes (malloc'ed; *size their count), or NULL. */
static unsigned char* Snapshot(const mdr_torsion* torsion, size_t* size) {
  if (mdr_torsion_snapshot(torsion, NULL, 0, size) != MDR_OUT_OF_RANGE) {
    Fail("snapshot size");
    return NULL;
  }
  unsigned char* bytes = malloc(*size);
  if (mdr_torsion_snapshot(torsion, bytes, *size, size) != MDR_OK) {
    Fail("snapshot");
    free(bytes);
    return NULL;
  }
  return bytes;
}

static int WriteSnapshot(const mdr_torsion* torsion, const char* path) {
  size_t size;
  unsigned char* bytes = Snapshot(torsion, &size);
  if (bytes == NULL) return 1;
  FILE* file = fopen(path, "wb");
  const int ok = file != NULL && fwrite(bytes, 1, size, file) == size;
  if (file != NULL) fclose(file);
  free(bytes);
  return ok ? 0 : 1;
}

/* The contact of the scene file's text, checked against the one of the serialized Scene. */
static mdr_torsion* Create(const char* dir, const char* scene_file) {
  size_t text_size, scene_size, a_size, b_size;
  char* text = ReadFile(scene_file, &text_size);
  char* scene = ReadReference(dir, "torsion_scene.pb", &scene_size);
  if (text == NULL || scene == NULL) {
    fprintf(stderr, "c_torsion: cannot read %s or the reference in %s\n", scene_file, dir);
    return NULL;
  }
  mdr_torsion *from_text = NULL, *from_bytes = NULL;
  if (mdr_torsion_create_from_text(text, scene_file, &from_text) != MDR_OK ||
      mdr_torsion_create(scene, scene_size, &from_bytes) != MDR_OK) {
    Fail("create");
    return NULL;
  }
  unsigned char* a = Snapshot(from_text, &a_size);
  unsigned char* b = Snapshot(from_bytes, &b_size);
  const int same = a != NULL && b != NULL && a_size == b_size && memcmp(a, b, a_size) == 0;
  free(a);
  free(b);
  free(text);
  free(scene);
  mdr_torsion_destroy(from_bytes);
  if (!same) {
    fprintf(stderr, "c_torsion: the scene file's contact differs from the Scene's\n");
    mdr_torsion_destroy(from_text);
    return NULL;
  }
  return from_text;
}

int main(int argc, char** argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: c_torsion REFERENCE_DIR SCENE_FILE SNAPSHOT_OUT\n");
    return 2;
  }
  if (!MDR_LAYOUT_MATCHES() || mdr_api_revision() < 3) {
    fprintf(stderr,
            "c_torsion: the library lays out the structs differently or predates torsion\n");
    return 1;
  }
  static history_step steps[kMaxSteps];
  const int count = ReadHistory(argv[1], steps);
  size_t snapshot_size;
  char* snapshot = ReadReference(argv[1], "torsion_snapshot.pb", &snapshot_size);
  if (count <= kRestoreAt || snapshot == NULL) {
    fprintf(stderr, "c_torsion: cannot read the reference in %s\n", argv[1]);
    return 1;
  }
  mdr_torsion* torsion = Create(argv[1], argv[2]);
  if (torsion == NULL) return 1;
  if (RunSteps(torsion, steps, 0, count) != 0) return 1;
  mdr_torsion_destroy(torsion);
  if (mdr_torsion_restore(snapshot, snapshot_size, &torsion) != MDR_OK) return Fail("restore");
  free(snapshot);
  if (RunSteps(torsion, steps, kRestoreAt, count) != 0) return 1;
  if (PrintFinals(torsion) != 0 || WriteSnapshot(torsion, argv[3]) != 0) return 1;
  mdr_torsion_destroy(torsion);
  return 0;
}
