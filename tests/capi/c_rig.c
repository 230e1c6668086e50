/* A rig controller in C on libmdr_c: a loop at a fixed rate (1 kHz, absolute deadlines) that
 * applies one step of the history per tick and reads the contact's state, as a hardware-in-the-
 * loop set-up would. It prints what tests/capi/service_reference.cc writes for the service
 * (reference.txt), which the test compares byte for byte, and writes its final snapshot for the
 * service to import.
 *
 *   c_rig REFERENCE_DIR SNAPSHOT_OUT
 *
 * The contact is created from the serialized Scene (scene.pb); after the history it is restored
 * from the service's snapshot (snapshot.pb) and repeats the second part. Missed deadlines are
 * reported on stderr (a shared test machine is no real-time system), never a failure. */
#define _POSIX_C_SOURCE 200809L
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mdr/mdr.h"

enum { kRestoreAt = 100, kMaxSteps = 4096, kRadii = 8 };
static const long kPeriodNs = 1000000; /* 1 kHz */

typedef struct {
  int normal_control, tangential_control;
  double normal_value, tangential_value;
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
  fprintf(stderr, "c_rig: %s: error %d, field '%s': %s\n", what, mdr_last_error_code(),
          mdr_last_error_field(), mdr_last_error_message());
  return 1;
}

static char* ReadFile(const char* dir, const char* name, size_t* size) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, name);
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

static int ReadHistory(const char* dir, history_step* steps) {
  size_t size;
  char* text = ReadFile(dir, "history.txt", &size);
  if (text == NULL) return -1;
  int count = 0;
  char normal[32], tangential[32];
  const char* line = text;
  int used;
  while (count < kMaxSteps &&
         sscanf(line, "%d %31s %d %31s%n", &steps[count].normal_control, normal,
                &steps[count].tangential_control, tangential, &used) == 4) {
    steps[count].normal_value = FromHex(normal);
    steps[count].tangential_value = FromHex(tangential);
    ++count;
    line += used;
  }
  free(text);
  return count;
}

static void AddNs(struct timespec* t, long ns) {
  t->tv_nsec += ns;
  while (t->tv_nsec >= 1000000000L) {
    t->tv_nsec -= 1000000000L;
    ++t->tv_sec;
  }
}

/* The rig loop: one step per tick; counts the ticks whose step finished after the deadline. */
static int RunLoop(mdr_contact* contact, const history_step* steps, int first, int last,
                   int* missed) {
  struct timespec deadline;
  clock_gettime(CLOCK_MONOTONIC, &deadline);
  for (int i = first; i < last; ++i) {
    AddNs(&deadline, kPeriodNs);
    mdr_state state;
    if (mdr_contact_step(contact, steps[i].normal_control, steps[i].normal_value,
                         steps[i].tangential_control, steps[i].tangential_value, NULL) != MDR_OK ||
        mdr_contact_state(contact, &state) != MDR_OK) {
      fprintf(stderr, "c_rig: step %d\n", i);
      return Fail("mdr_contact_step");
    }
    printf("S");
    PrintHex(state.depth);
    PrintHex(state.tangential_displacement);
    PrintHex(state.contact_radius);
    PrintHex(state.normal_force);
    PrintHex(state.tangential_force);
    PrintHex(state.dissipated_energy);
    printf("\n");
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if (now.tv_sec > deadline.tv_sec ||
        (now.tv_sec == deadline.tv_sec && now.tv_nsec > deadline.tv_nsec)) {
      ++*missed;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, NULL);
  }
  return 0;
}

static int PrintFinals(const mdr_contact* contact) {
  double positive, negative, edge;
  if (mdr_contact_stiffness(contact, &positive, &negative) != MDR_OK) return Fail("stiffness");
  printf("K");
  PrintHex(positive);
  PrintHex(negative);
  printf("\n");
  size_t count;
  /* Ask for the size first, as a caller without a bound would. */
  if (mdr_contact_jager_weights(contact, NULL, NULL, NULL, 0, &count, NULL) != MDR_OUT_OF_RANGE &&
      count > 0) {
    return Fail("jager_weights without room");
  }
  double* r_begin = malloc((count + 1) * sizeof(double));
  double* r_end = malloc((count + 1) * sizeof(double));
  double* weight = malloc((count + 1) * sizeof(double));
  if (mdr_contact_jager_weights(contact, r_begin, r_end, weight, count, &count, &edge) != MDR_OK) {
    return Fail("jager_weights");
  }
  printf("J %zu", count);
  PrintHex(edge);
  printf("\n");
  for (size_t i = 0; i < count; ++i) {
    printf("W");
    PrintHex(r_begin[i]);
    PrintHex(r_end[i]);
    PrintHex(weight[i]);
    printf("\n");
  }
  mdr_state state;
  mdr_contact_state(contact, &state);
  double radii[kRadii], tau[kRadii], tau_error[kRadii], p[kRadii], p_error[kRadii];
  for (int k = 0; k < kRadii; ++k) radii[k] = state.contact_radius * k / 8;
  if (mdr_contact_tractions(contact, radii, kRadii, MDR_ROUTE_BOTH, tau, tau_error, p, p_error,
                            kRadii) != MDR_OK) {
    return Fail("tractions");
  }
  for (int k = 0; k < kRadii; ++k) {
    printf("T");
    PrintHex(tau[k]);
    PrintHex(tau_error[k]);
    PrintHex(p[k]);
    PrintHex(p_error[k]);
    printf("\n");
  }
  size_t slips;
  if (mdr_contact_slip_intervals(contact, NULL, NULL, NULL, 0, &slips) != MDR_OUT_OF_RANGE &&
      slips > 0) {
    return Fail("slip_intervals without room");
  }
  double* s_begin = malloc((slips + 1) * sizeof(double));
  double* s_end = malloc((slips + 1) * sizeof(double));
  int32_t* direction = malloc((slips + 1) * sizeof(int32_t));
  if (mdr_contact_slip_intervals(contact, s_begin, s_end, direction, slips, &slips) != MDR_OK) {
    return Fail("slip_intervals");
  }
  printf("L %zu\n", slips);
  for (size_t i = 0; i < slips; ++i) {
    printf("I");
    PrintHex(s_begin[i]);
    PrintHex(s_end[i]);
    printf(" %d\n", (int)direction[i]);
  }
  free(s_begin);
  free(s_end);
  free(direction);
  free(r_begin);
  free(r_end);
  free(weight);
  return 0;
}

static int WriteSnapshot(const mdr_contact* contact, const char* path) {
  size_t size;
  if (mdr_contact_snapshot(contact, NULL, 0, &size) != MDR_OUT_OF_RANGE) return Fail("size");
  char* bytes = malloc(size);
  if (mdr_contact_snapshot(contact, bytes, size, &size) != MDR_OK) return Fail("snapshot");
  FILE* file = fopen(path, "wb");
  const int ok = file != NULL && fwrite(bytes, 1, size, file) == size;
  if (file != NULL) fclose(file);
  free(bytes);
  return ok ? 0 : 1;
}

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: c_rig REFERENCE_DIR SNAPSHOT_OUT\n");
    return 2;
  }
  if (mdr_version() != MDR_C_API_VERSION) {
    fprintf(stderr, "c_rig: built for interface %d, loaded %d\n", MDR_C_API_VERSION, mdr_version());
    return 1;
  }
  static history_step steps[kMaxSteps];
  const int count = ReadHistory(argv[1], steps);
  size_t scene_size, snapshot_size;
  char* scene = ReadFile(argv[1], "scene.pb", &scene_size);
  char* snapshot = ReadFile(argv[1], "snapshot.pb", &snapshot_size);
  if (count <= kRestoreAt || scene == NULL || snapshot == NULL) {
    fprintf(stderr, "c_rig: cannot read the reference in %s\n", argv[1]);
    return 1;
  }
  mdr_contact* contact;
  if (mdr_contact_create(scene, scene_size, &contact) != MDR_OK) return Fail("create");
  int missed = 0;
  if (RunLoop(contact, steps, 0, count, &missed) != 0) return 1;
  mdr_contact_destroy(contact);
  if (mdr_contact_restore(snapshot, snapshot_size, &contact) != MDR_OK) return Fail("restore");
  if (RunLoop(contact, steps, kRestoreAt, count, &missed) != 0) return 1;
  if (PrintFinals(contact) != 0 || WriteSnapshot(contact, argv[2]) != 0) return 1;
  mdr_contact_destroy(contact);
  free(scene);
  free(snapshot);
  fprintf(stderr, "c_rig: %d steps at 1 kHz, %d deadlines missed\n", count + count - kRestoreAt,
          missed);
  return 0;
}
