/* stand-in: PX4 px4_platform_common/module_params.h; px4::params lists the parameters used here */
#pragma once

namespace px4
{
enum class params { DOBW_EN, MPC_THR_HOVER };
} // namespace px4

template<px4::params p> class ParamBool
{
public:
	bool get() const;
};

template<px4::params p> class ParamInt
{
public:
	int get() const;
};

template<px4::params p> class ParamFloat
{
public:
	float get() const;
};

class ModuleParams
{
public:
	explicit ModuleParams(ModuleParams *parent);
	virtual ~ModuleParams() = default;

protected:
	virtual void updateParams();
};

/* DEFINE_PARAMETERS((Type) name, ...): each "(Type) name" becomes the member "Type name;" */
#define PX4_STANDIN_TYPE_(...) __VA_ARGS__
#define PX4_STANDIN_DECL_(typed_name) PX4_STANDIN_TYPE_ typed_name;
#define PX4_STANDIN_N_(_1, _2, _3, _4, N, ...) N
#define PX4_STANDIN_1_(a) PX4_STANDIN_DECL_(a)
#define PX4_STANDIN_2_(a, b) PX4_STANDIN_DECL_(a) PX4_STANDIN_DECL_(b)
#define PX4_STANDIN_3_(a, b, c) PX4_STANDIN_DECL_(a) PX4_STANDIN_DECL_(b) PX4_STANDIN_DECL_(c)
#define PX4_STANDIN_4_(a, b, c, d) PX4_STANDIN_DECL_(a) PX4_STANDIN_DECL_(b) PX4_STANDIN_DECL_(c) PX4_STANDIN_DECL_(d)
#define PX4_STANDIN_PICK_(...) PX4_STANDIN_N_(__VA_ARGS__, PX4_STANDIN_4_, PX4_STANDIN_3_, PX4_STANDIN_2_, PX4_STANDIN_1_, 0)
#define DEFINE_PARAMETERS(...) PX4_STANDIN_PICK_(__VA_ARGS__)(__VA_ARGS__)
