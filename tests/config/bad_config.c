/* Must NOT compile: config.h's consistency checks reject the value given
 * on the command line (-DDKF_USE_FLOAT=2, -DDKF_MAX_DIM=0, ...). */
#include "dkf/config.h"
int dkf_bad_config_anchor(void);
int dkf_bad_config_anchor(void) { return 0; }
