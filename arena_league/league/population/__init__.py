"""Base populations: the build (:mod:`.build`, run in stages: :mod:`.recipes`, :mod:`.runs`,
:mod:`.round_robin`, :mod:`.figures` with :mod:`.selection`, :mod:`.freeze`, :mod:`.readme`),
its options (:mod:`.options`) and loading a frozen population (:mod:`.loading`)."""
