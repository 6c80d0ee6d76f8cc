/* placeholder: being written */
typedef int dkf_placeholder_kf_t;
