import type { ReactNode } from 'react';

/** A titled landmark region (tests and screen readers find it by its name). */
export function Panel({
  label,
  title,
  actions,
  children,
  className = '',
}: {
  label: string;
  title?: ReactNode;
  actions?: ReactNode;
  children: ReactNode;
  className?: string;
}) {
  return (
    <section aria-label={label} className={`rounded-lg border border-line bg-surface ${className}`}>
      {(title ?? actions) && (
        <header className="flex items-center justify-between gap-2 border-b border-line px-3 py-2">
          <h2 className="text-sm font-semibold">{title ?? label}</h2>
          {actions}
        </header>
      )}
      {children}
    </section>
  );
}
