// stand-in: ArduPilot AP_Param/AP_Param.h (GroupInfo tables, AP_Int8)
#pragma once
#include <stddef.h>
#include <stdint.h>

#define AP_PARAM_FLAG_ENABLE (1 << 4)

enum ap_var_type { AP_PARAM_NONE = 0, AP_PARAM_INT8 = 1, AP_PARAM_GROUP = 6 };

class AP_Param {
public:
    struct GroupInfo {
        const char *name;
        ptrdiff_t offset;
        union {
            const struct GroupInfo *group_info;
            const float def_value;
        };
        uint16_t flags;
        uint8_t idx;
        uint8_t type;
    };
    static void setup_object_defaults(const void *object_pointer, const struct GroupInfo *group_info);
};

class AP_Int8 {
public:
    operator int8_t() const { return _value; }
    int8_t get() const { return _value; }
    static constexpr ap_var_type vtype = AP_PARAM_INT8;
private:
    int8_t _value;
};

#define AP_VAROFFSET(type, element) (((ptrdiff_t)(&((const type *)1)->element))-1)
#define AP_CLASSTYPE(clazz, element) ((uint8_t)(((const clazz *) 1)->element.vtype))
#define AP_GROUPINFO_FLAGS(name, idx, clazz, element, def, flags) \
    { name, AP_VAROFFSET(clazz, element), {def_value : def}, flags, idx, AP_CLASSTYPE(clazz, element) }
#define AP_GROUPINFO(name, idx, clazz, element, def) AP_GROUPINFO_FLAGS(name, idx, clazz, element, def, 0)
#define AP_GROUPEND { "", 0, { group_info : nullptr }, 0, 0xFF, AP_PARAM_NONE }
