"""The dishwasher task's skills: turning a dish over on the counter (which tilts,
:mod:`.turn_over`; the Panda drivers' manoeuvre, :mod:`.panda_turn_over`). Its loading rules
are every service's (``manigraph_shared.dishwasher_rules``); its tray action is the drivers'
``toggle_tray``."""
