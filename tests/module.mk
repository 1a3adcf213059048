# tests/module.mk: includes the tests/*.mk fragments, one per owner, so that
# each can add check and bench targets without touching a shared file.
-include $(sort $(filter-out tests/module.mk,$(wildcard tests/*.mk)))
