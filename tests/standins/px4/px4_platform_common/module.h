/* stand-in: PX4 px4_platform_common/module.h (ModuleBase) */
#pragma once
#include <px4_platform_common/log.h>

namespace px4
{
template<class T> class atomic
{
public:
	void store(T value);
	T load() const;
};
} // namespace px4

static constexpr int task_id_is_work_queue = -2;

template<class T> class ModuleBase
{
public:
	virtual ~ModuleBase() = default;
	static int main(int argc, char *argv[]);
	virtual int print_status();
	bool should_exit() const;
	static void exit_and_cleanup();

protected:
	static px4::atomic<T *> _object;
	static int _task_id;
};

template<class T> px4::atomic<T *> ModuleBase<T>::_object;
template<class T> int ModuleBase<T>::_task_id = -1;

void px4_module_usage_stub(const char *text);
#define PRINT_MODULE_DESCRIPTION(text) px4_module_usage_stub(text)
#define PRINT_MODULE_USAGE_NAME(name, category) px4_module_usage_stub(name)
#define PRINT_MODULE_USAGE_COMMAND(name) px4_module_usage_stub(name)
#define PRINT_MODULE_USAGE_DEFAULT_COMMANDS() px4_module_usage_stub("")
