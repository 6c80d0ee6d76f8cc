/* placeholder: being written */
typedef int dkf_placeholder_info_t;
