/* A C program outside the project, built against an installed and then moved libmdr_c with
 * nothing but pkg-config: it checks the library's layout, runs a few fretting steps and prints
 * the tangential force. */
#include <mdr/mdr.h>
#include <stdio.h>

static const char kScene[] =
    "scene:\n"
    "  sphere: {radius: 0.01}\n"
    "  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3,\n"
    "                 youngs_modulus_2: 210e9, poisson_ratio_2: 0.3}\n"
    "  friction: 0.3\n";

int main(void) {
  mdr_contact* contact = NULL;
  mdr_state state;
  if (!MDR_LAYOUT_MATCHES()) {
    fprintf(stderr, "the loaded libmdr_c lays out its structs differently\n");
    return 1;
  }
  if (mdr_contact_create_from_text(kScene, "outside", &contact) != MDR_OK ||
      mdr_contact_step(contact, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, NULL) != MDR_OK ||
      mdr_contact_step(contact, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, 5e-7, NULL) !=
          MDR_OK ||
      mdr_contact_state(contact, &state) != MDR_OK) {
    fprintf(stderr, "%s\n", mdr_last_error_message());
    return 1;
  }
  printf("libmdr_c %s: F_x = %.6g N at ux = %.3g m\n", mdr_version_string(), state.tangential_force,
         state.tangential_displacement);
  mdr_contact_destroy(contact);
  return state.tangential_force > 0 ? 0 : 1;
}
