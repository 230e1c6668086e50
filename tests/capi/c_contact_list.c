/* A discrete-element style caller in C on libmdr_c: one mdr_interface holds a contact list and
 * every time step passes one value per contact and channel, as a DEM code updates its contacts.
 * It prints what tests/capi/service_reference.cc writes for the service's interface session
 * (list_reference.txt), which the test compares byte for byte.
 *
 *   c_contact_list REFERENCE_DIR SCENE_FILE */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mdr/mdr.h"

enum { kMaxContacts = 64 };

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
  fprintf(stderr, "c_contact_list: %s: error %d, field '%s': %s\n", what, mdr_last_error_code(),
          mdr_last_error_field(), mdr_last_error_message());
  return 1;
}

static char* ReadText(const char* path) {
  FILE* file = fopen(path, "rb");
  if (file == NULL) return NULL;
  fseek(file, 0, SEEK_END);
  long length = ftell(file);
  fseek(file, 0, SEEK_SET);
  char* text = malloc((size_t)length + 1);
  size_t read = fread(text, 1, (size_t)length, file);
  text[read] = '\0';
  fclose(file);
  return text;
}

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: c_contact_list REFERENCE_DIR SCENE_FILE\n");
    return 2;
  }
  char* scene = ReadText(argv[2]);
  char path[4096];
  snprintf(path, sizeof path, "%s/list_history.txt", argv[1]);
  FILE* history = fopen(path, "r");
  if (scene == NULL || history == NULL) {
    fprintf(stderr, "c_contact_list: cannot read %s or %s\n", argv[2], path);
    return 1;
  }
  mdr_interface* contacts;
  if (mdr_interface_create_from_text(scene, argv[2], &contacts) != MDR_OK) return Fail("create");
  size_t n;
  mdr_interface_size(contacts, &n);
  if (n > kMaxContacts) return Fail("size");
  double normal[kMaxContacts], tangential[kMaxContacts];
  mdr_state states[kMaxContacts], total;
  int normal_control, tangential_control;
  char hex[32];
  while (fscanf(history, "%d %d", &normal_control, &tangential_control) == 2) {
    for (size_t i = 0; i < 2 * n; ++i) {
      if (fscanf(history, "%31s", hex) != 1) return Fail("history");
      (i < n ? normal : tangential)[i % n] = FromHex(hex);
    }
    if (mdr_interface_step(contacts, normal_control, 0, tangential_control, 0,
                           normal_control == MDR_NORMAL_HOLD ? NULL : normal,
                           tangential_control == MDR_TANGENTIAL_HOLD ? NULL : tangential,
                           n) != MDR_OK) {
      return Fail("step");
    }
    if (mdr_interface_contact_states(contacts, states, kMaxContacts, &n) != MDR_OK ||
        mdr_interface_state(contacts, &total) != MDR_OK) {
      return Fail("state");
    }
    printf("S");
    for (size_t i = 0; i < n; ++i) {
      PrintHex(states[i].depth);
      PrintHex(states[i].tangential_displacement);
      PrintHex(states[i].normal_force);
      PrintHex(states[i].tangential_force);
      PrintHex(states[i].dissipated_energy);
    }
    printf("\nT");
    PrintHex(total.normal_force);
    PrintHex(total.tangential_force);
    PrintHex(total.dissipated_energy);
    printf("\n");
  }
  fclose(history);
  mdr_interface_destroy(contacts);
  free(scene);
  return 0;
}
