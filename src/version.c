#include "dkf/version.h"

const char *dkf_version_str(void)
{
    return DKF_VERSION_STRING;
}
